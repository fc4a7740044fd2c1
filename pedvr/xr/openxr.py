"""The thin layer of real pyopenxr calls behind :class:`pedvr.xr.session.XrPort`.

Instance with ``XR_KHR_opengl_enable`` (and, where the runtime offers them,
``XR_MNDX_egl_enable``, ``XR_EXT_local_floor``, ``XR_FB_display_refresh_rate``
and ``XR_EXT_eye_gaze_interaction``); the HMD system; an OpenGL context bound
through EGL where the runtime takes one (no X server needed; issue 23 item 7),
else through GLX from a hidden glfw window; the session; a LOCAL_FLOOR reference
space (else STAGE, else LOCAL raised by a standing eye height); one
swapchain per eye, sRGB when offered, its images wrapped as moderngl
textures with a depth buffer each; actions (left stick / trackpad move,
right stick snap turn, trigger, menu, and each hand's grip pose through an
action space located every frame in the reference space) with suggested
bindings for the common controller profiles. All decisions live in :mod:`pedvr.xr.session` and are
tested with a fake port; this module only translates.

Every failure to start is a :class:`~pedvr.errors.BackendUnavailableError`
with one line naming the cause and what to do; a runtime lost while running
(killed, crashed) is a :class:`~pedvr.xr.session.RuntimeLostError` with one
line, which the presenter turns into :attr:`~pedvr.xr.session.XrPresenter.lost`.

``PEDVR_XR_CONTEXT=glx`` forces the glfw/GLX context even where EGL is offered
(``egl`` refuses to fall back): for a driver whose EGL path misbehaves, and for
testing both. ``PEDVR_XR_CAPTURE=DIR`` saves the first drawn frame's eyes as
the runtime received them, read back from the swapchain images
(``DIR/eye0.png``, ``DIR/eye1.png``, and ``DIR/views.json`` with each eye's
pose and field of view): what a participant saw first, for a lab's records
and for the golden tests against Monado.
"""

from __future__ import annotations

import contextlib
import ctypes
import enum
import functools
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from pedvr.errors import BackendUnavailableError
from pedvr.xr.locomotion import Controls
from pedvr.xr.session import (
    InstanceLossPending,
    Pose,
    RuntimeLostError,
    SessionState,
    StateChanged,
    ViewLocation,
    XrEvent,
    XrFrame,
)

GL_SRGB8_ALPHA8 = 0x8C43
GL_RGBA8 = 0x8058
GL_FRAMEBUFFER_SRGB = 0x8DB9
STANDING_EYE_HEIGHT = 1.65  # m, added when only a LOCAL (head-height) space exists

# Each hand's grip pose (issue 14: the trigger takes a door with the controller near the handle);
# every profile below has it.
GRIP = ("/user/hand/left/input/grip/pose", "/user/hand/right/input/grip/pose")

# Suggested bindings: interaction profile -> action name -> input paths.
BINDINGS: dict[str, dict[str, tuple[str, ...]]] = {
    "/interaction_profiles/khr/simple_controller": {
        "trigger": ("/user/hand/right/input/select/click", "/user/hand/left/input/select/click"),
        "menu": ("/user/hand/left/input/menu/click", "/user/hand/right/input/menu/click"),
        "grip": GRIP,
    },
    "/interaction_profiles/oculus/touch_controller": {
        "move": ("/user/hand/left/input/thumbstick",),
        "turn": ("/user/hand/right/input/thumbstick",),
        "trigger": ("/user/hand/right/input/trigger/value", "/user/hand/left/input/trigger/value"),
        "menu": ("/user/hand/left/input/menu/click",),
        "grip": GRIP,
    },
    "/interaction_profiles/valve/index_controller": {
        "move": ("/user/hand/left/input/thumbstick",),
        "turn": ("/user/hand/right/input/thumbstick",),
        "trigger": ("/user/hand/right/input/trigger/click", "/user/hand/left/input/trigger/click"),
        "menu": ("/user/hand/left/input/b/click",),
        "grip": GRIP,
    },
    "/interaction_profiles/htc/vive_controller": {
        "move": ("/user/hand/left/input/trackpad",),
        "turn": ("/user/hand/right/input/trackpad",),
        "trigger": ("/user/hand/right/input/trigger/click", "/user/hand/left/input/trigger/click"),
        "menu": ("/user/hand/left/input/menu/click", "/user/hand/right/input/menu/click"),
        "grip": GRIP,
    },
    "/interaction_profiles/microsoft/motion_controller": {
        "move": ("/user/hand/left/input/thumbstick",),
        "turn": ("/user/hand/right/input/thumbstick",),
        "trigger": ("/user/hand/right/input/trigger/value", "/user/hand/left/input/trigger/value"),
        "menu": ("/user/hand/left/input/menu/click", "/user/hand/right/input/menu/click"),
        "grip": GRIP,
    },
}

# Extensions used where offered (XR_KHR_opengl_enable is required).
OPTIONAL_EXTENSIONS = (
    "XR_MNDX_egl_enable",  # an EGL context: xr without an X server (issue 23 item 7)
    "XR_EXT_local_floor",  # LOCAL_FLOOR in OpenXR 1.0 needs it enabled
    "XR_FB_display_refresh_rate",  # the display's real refresh rate (issue 23 item 6)
    "XR_EXT_eye_gaze_interaction",  # reported by `pedvr xr check`; not bound
)
CONTEXT_ENV = "PEDVR_XR_CONTEXT"
CAPTURE_ENV = "PEDVR_XR_CAPTURE"

NO_RUNTIME = (
    "no OpenXR runtime is active (the loader found none: start SteamVR, Monado or Meta Quest Link, "
    "or set XR_RUNTIME_JSON)"
)


def _import_xr() -> Any:
    # The loader prints its own multi-line errors to stderr unless told not to; we report one line.
    os.environ.setdefault("XR_LOADER_DEBUG", "none")
    try:
        import xr
    except ImportError as exc:
        raise BackendUnavailableError(
            f"pyopenxr is not installed ({exc.name}); pip install pyopenxr"
        ) from None
    return xr


def _float(value: Any) -> float:
    """A float from pyopenxr's answers, some of which are still ``ctypes.c_float``."""
    return float(value.value) if isinstance(value, ctypes.c_float) else float(value)


def _text(value: bytes | str) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


def describe_xr_error(exc: BaseException) -> str:
    """One line for an OpenXR failure at start-up (the cause, then what to do)."""
    xr = _import_xr()
    if isinstance(exc, xr.RuntimeUnavailableError):
        return NO_RUNTIME
    if isinstance(exc, xr.FormFactorUnavailableError):
        return "the OpenXR runtime reports no headset connected (plug it in and wake it up)"
    if isinstance(exc, xr.ExtensionNotPresentError):
        return "the OpenXR runtime has no OpenGL support (XR_KHR_opengl_enable)"
    return f"OpenXR error {type(exc).__name__}: {str(exc).strip() or 'no details'}"


F = TypeVar("F", bound=Callable[..., Any])


def _lost_guard(method: F) -> F:
    """Turn the runtime's "lost" answers inside a per-frame call into :class:`RuntimeLostError`."""

    @functools.wraps(method)
    def call(self: OpenXRPort, *args: Any, **kwargs: Any) -> Any:
        xr = self.xr
        try:
            return method(self, *args, **kwargs)
        except (xr.SessionLostError, xr.InstanceLostError, xr.RuntimeFailureError) as exc:
            raise RuntimeLostError(
                f"the OpenXR runtime went away ({type(exc).__name__.removesuffix('Error')} in "
                f"{method.__name__}): restart it (monado-service, SteamVR ...) and run again"
            ) from None

    return call  # type: ignore[return-value]


def probe_openxr() -> str | None:
    """None when an OpenXR runtime with an HMD and OpenGL support answers; else one line saying why not."""
    try:
        xr = _import_xr()
    except BackendUnavailableError as exc:
        return str(exc)
    instance = None
    try:
        instance = xr.create_instance(
            xr.InstanceCreateInfo(
                application_info=xr.ApplicationInfo(application_name="pedvr-probe", engine_name="pedvr"),
                enabled_extension_names=[xr.KHR_OPENGL_ENABLE_EXTENSION_NAME],
            )
        )
        xr.get_system(instance, xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY))
    except xr.XrException as exc:
        return describe_xr_error(exc)
    finally:
        if instance is not None:
            xr.destroy_instance(instance)
    return None


class OpenXRPort:
    """The real :class:`~pedvr.xr.session.XrPort`. Construct with :meth:`open`."""

    def __init__(self) -> None:
        self.xr = _import_xr()
        self.instance: Any = None
        self.system: Any = None
        self.session: Any = None
        self.space: Any = None
        self.view_space: Any = None
        self.window: Any = None
        self.ctx: Any = None
        self.swapchains: list[Any] = []
        self.targets: list[list[Any]] = []  # per eye, per swapchain image: (texture, depth, framebuffer)
        self.sizes: list[tuple[int, int]] = []
        self.srgb = False
        self.space_kind = ""
        self._height_offset = 0.0
        self._time = 0
        self._acquired: list[int] = []
        self._actions: dict[str, Any] = {}
        self._action_set: Any = None
        self._hands: list[Any] = []
        self._grip_spaces: list[Any] = []  # left, right: the grip pose's action spaces
        self._prev_buttons = {"trigger": False, "menu": False}
        self.extensions: set[str] = set()  # offered by the runtime
        self.enabled: list[str] = []
        self.context_kind = ""  # "EGL" or "GLX"
        self.egl_failed = ""  # why EGL was offered but not used (GLX was)
        self._egl: tuple[_Egl, int, int] | None = None  # libEGL, display, context: destroyed in close()
        self.refresh_hz: float | None = None
        capture = os.environ.get(CAPTURE_ENV, "").strip()
        self.capture: Path | None = Path(capture) if capture else None
        self._captured: set[int] = set()

    @classmethod
    def open(cls) -> OpenXRPort:
        port = cls()
        try:
            port._start()
        except BackendUnavailableError:
            port.close()
            raise
        except port.xr.XrException as exc:
            port.close()
            raise BackendUnavailableError(
                f"cannot start the OpenXR backend: {describe_xr_error(exc)}; "
                "use --backend desktop or --backend headless"
            ) from None
        return port

    # -- start-up --------------------------------------------------------------------------

    def _start(self) -> None:
        xr = self.xr
        self.extensions = {
            _text(e.extension_name) for e in xr.enumerate_instance_extension_properties()
        }
        self.enabled = [xr.KHR_OPENGL_ENABLE_EXTENSION_NAME] + [
            e for e in OPTIONAL_EXTENSIONS if e in self.extensions
        ]
        self.instance = xr.create_instance(
            xr.InstanceCreateInfo(
                application_info=xr.ApplicationInfo(application_name="pedvr", engine_name="pedvr"),
                enabled_extension_names=self.enabled,
            )
        )
        self.system = xr.get_system(
            self.instance, xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY)
        )
        binding = self._gl_context()
        # xrGetOpenGLGraphicsRequirementsKHR must be called before xrCreateSession.
        get_req = ctypes.cast(
            xr.get_instance_proc_addr(self.instance, "xrGetOpenGLGraphicsRequirementsKHR"),
            xr.PFN_xrGetOpenGLGraphicsRequirementsKHR,
        )
        req = xr.GraphicsRequirementsOpenGLKHR()
        result = xr.check_result(xr.Result(get_req(self.instance, self.system, ctypes.byref(req))))
        if result.is_exception():
            raise result
        self.session = xr.create_session(
            self.instance,
            xr.SessionCreateInfo(
                next=ctypes.cast(ctypes.pointer(binding), ctypes.c_void_p), system_id=self.system
            ),
        )
        self._binding = binding  # keep alive
        self._reference_space()
        self._swapchains()
        self._actions_setup()
        if "XR_FB_display_refresh_rate" in self.enabled:
            rate = _float(xr.get_display_refresh_rate_fb(self.session))
            self.refresh_hz = rate if rate > 0 else None

    def _gl_context(self) -> Any:
        """Make the OpenGL context and return its graphics binding: EGL where the runtime takes
        it and :data:`CONTEXT_ENV` allows, else GLX through a hidden glfw window."""
        want = os.environ.get(CONTEXT_ENV, "").strip().lower()
        if want not in ("", "egl", "glx"):
            raise BackendUnavailableError(
                f"{CONTEXT_ENV}={want!r}: expected egl or glx (or unset: EGL where the runtime offers it)"
            )
        if want != "glx" and "XR_MNDX_egl_enable" in self.enabled:
            try:
                return self._egl_context()
            except BackendUnavailableError as exc:
                if want == "egl":
                    raise
                self._release_egl()
                self.egl_failed = str(exc)  # try GLX; if that fails too, its error says both
        if want == "egl":
            raise BackendUnavailableError(
                f"cannot start the OpenXR backend: {CONTEXT_ENV}=egl, but the runtime does not offer "
                "XR_MNDX_egl_enable; unset it to use GLX"
            )
        return self._glx_context()

    def _egl_context(self) -> Any:
        """An OpenGL 3.3 core context on EGL with no surface, bound through ``XR_MNDX_egl_enable``.

        The display is Mesa's surfaceless platform where offered, else the default display: no X
        server needed. libEGL is called through ctypes (PyOpenGL's wrapper of
        ``eglGetPlatformDisplay`` hands back a display that ``eglInitialize`` refuses)."""

        def fail(what: str) -> BackendUnavailableError:
            return BackendUnavailableError(
                f"cannot start the OpenXR backend: no EGL OpenGL 3.3 context ({what}); "
                f"set {CONTEXT_ENV}=glx to use an X display instead"
            )

        try:
            egl = _Egl()
        except OSError as exc:
            raise fail(f"libEGL: {exc}") from None
        display = egl.display()
        major, minor = ctypes.c_int(), ctypes.c_int()
        if not display or not egl.lib.eglInitialize(display, ctypes.byref(major), ctypes.byref(minor)):
            raise fail(f"eglInitialize failed, error 0x{egl.lib.eglGetError():x}")
        attribs = (ctypes.c_int * 13)(
            EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
            EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_NONE,
        )
        config, count = ctypes.c_void_p(), ctypes.c_int()
        if not egl.lib.eglChooseConfig(display, attribs, ctypes.byref(config), 1, ctypes.byref(count)) \
                or count.value < 1:
            raise fail("no RGBA8 + depth config")
        if not egl.lib.eglBindAPI(EGL_OPENGL_API):
            raise fail("eglBindAPI(OpenGL) failed")
        ctx_attribs = (ctypes.c_int * 7)(
            EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
            EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE,
        )
        context = egl.lib.eglCreateContext(display, config, None, ctx_attribs)
        if not context:
            raise fail(f"eglCreateContext failed, error 0x{egl.lib.eglGetError():x}")
        self._egl = (egl, display, context)
        if not egl.lib.eglMakeCurrent(display, None, None, context):
            raise fail("eglMakeCurrent without a surface failed (EGL_KHR_surfaceless_context)")
        import moderngl

        proc = ctypes.cast(egl.lib.eglGetProcAddress, ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_char_p))

        class Loader:  # moderngl's loader protocol: GL entry points of the current EGL context
            def load_opengl_function(self, name: str) -> int:
                return int(proc(name.encode()) or 0)

            def release(self) -> None:
                pass

        try:
            self.ctx = moderngl.create_context(require=330, context=Loader())  # type: ignore[arg-type]
        except Exception as exc:  # an old moderngl (no context= loader) or no GL 3.3 on this EGL
            raise fail(f"moderngl: {str(exc).strip() or type(exc).__name__}") from None
        self.context_kind = "EGL"
        xr = self.xr
        fields = dict(xr.GraphicsBindingEGLMNDX._fields_)

        def handle(name: str, value: int | None) -> Any:
            return ctypes.cast(ctypes.c_void_p(value), fields[name])

        return xr.GraphicsBindingEGLMNDX(
            get_proc_address=ctypes.cast(egl.lib.eglGetProcAddress, xr.PFN_xrEglGetProcAddressMNDX),
            display=handle("display", display),
            config=handle("config", config.value),
            context=handle("context", context),
        )

    def _glx_context(self) -> Any:
        try:
            self._gl_window()
        except BackendUnavailableError as exc:
            if self.egl_failed:
                raise BackendUnavailableError(f"{exc} (and EGL: {self.egl_failed})") from None
            raise
        # The binding's fields are PyOpenGL GLX types; read them from the current context (as
        # pyopenxr's own GLXGraphicsBinding does) rather than casting glfw's raw handles.
        from OpenGL import GLX

        self.context_kind = "GLX"
        return self.xr.GraphicsBindingOpenGLXlibKHR(
            x_display=GLX.glXGetCurrentDisplay(),
            glx_drawable=GLX.glXGetCurrentDrawable(),
            glx_context=GLX.glXGetCurrentContext(),
        )

    def _gl_window(self) -> None:
        import glfw
        import moderngl

        if not glfw.init():
            raise BackendUnavailableError(
                "cannot start the OpenXR backend: no display for the OpenGL context "
                "(glfw could not initialise: no X display, and no EGL context through "
                "XR_MNDX_egl_enable); use --backend headless"
            )
        glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.DOUBLEBUFFER, glfw.FALSE)
        self.window = glfw.create_window(64, 64, "pedvr (OpenXR)", None, None)
        if not self.window:
            raise BackendUnavailableError(
                "cannot start the OpenXR backend: no OpenGL 3.3 context "
                "(glfw window creation failed); use --backend headless"
            )
        glfw.make_context_current(self.window)
        glfw.swap_interval(0)  # the runtime paces frames in xrWaitFrame
        self.ctx = moderngl.create_context(require=330)

    def _reference_space(self) -> None:
        xr = self.xr
        offered = set(xr.enumerate_reference_spaces(self.session))
        for kind, name in (
            (xr.ReferenceSpaceType.LOCAL_FLOOR, "LOCAL_FLOOR"),
            (xr.ReferenceSpaceType.STAGE, "STAGE"),
            (xr.ReferenceSpaceType.LOCAL, "LOCAL"),
        ):
            if kind in offered or kind.value in offered:
                self.space = xr.create_reference_space(
                    self.session,
                    xr.ReferenceSpaceCreateInfo(
                        reference_space_type=kind, pose_in_reference_space=xr.Posef()
                    ),
                )
                self.space_kind = name
                self._height_offset = STANDING_EYE_HEIGHT if name == "LOCAL" else 0.0
                break
        else:
            raise BackendUnavailableError(
                "cannot start the OpenXR backend: the runtime offers no LOCAL_FLOOR, "
                "STAGE or LOCAL space; use --backend desktop"
            )
        self.view_space = xr.create_reference_space(
            self.session,
            xr.ReferenceSpaceCreateInfo(
                reference_space_type=xr.ReferenceSpaceType.VIEW, pose_in_reference_space=xr.Posef()
            ),
        )

    def _swapchains(self) -> None:
        xr = self.xr

        views = xr.enumerate_view_configuration_views(
            self.instance, self.system, xr.ViewConfigurationType.PRIMARY_STEREO
        )
        formats = list(xr.enumerate_swapchain_formats(self.session))
        fmt = (
            GL_SRGB8_ALPHA8 if GL_SRGB8_ALPHA8 in formats else GL_RGBA8 if GL_RGBA8 in formats else formats[0]
        )
        self.srgb = fmt == GL_SRGB8_ALPHA8
        self._format = int(fmt)
        for v in views:
            w, h = v.recommended_image_rect_width, v.recommended_image_rect_height
            sc = xr.create_swapchain(
                self.session,
                xr.SwapchainCreateInfo(
                    usage_flags=xr.SwapchainUsageFlags.COLOR_ATTACHMENT_BIT
                    | xr.SwapchainUsageFlags.SAMPLED_BIT,
                    format=fmt,
                    sample_count=1,
                    width=w,
                    height=h,
                    face_count=1,
                    array_size=1,
                    mip_count=1,
                ),
            )
            images = xr.enumerate_swapchain_images(sc, xr.SwapchainImageOpenGLKHR)
            eye = []
            for img in images:
                tex = self.ctx.external_texture(int(img.image), (w, h), 4, 0, "f1")
                depth = self.ctx.depth_renderbuffer((w, h))
                eye.append(
                    (tex, depth, self.ctx.framebuffer(color_attachments=[tex], depth_attachment=depth))
                )
            self.swapchains.append(sc)
            self.targets.append(eye)
            self.sizes.append((w, h))
        if self.srgb:
            self.ctx.enable_direct(GL_FRAMEBUFFER_SRGB)

    def _actions_setup(self) -> None:
        xr = self.xr
        path = lambda s: xr.string_to_path(self.instance, s)  # noqa: E731
        self._hands = [path("/user/hand/left"), path("/user/hand/right")]
        self._action_set = xr.create_action_set(
            self.instance,
            xr.ActionSetCreateInfo(action_set_name="pedvr", localized_action_set_name="pedvr", priority=0),
        )
        kinds = {
            "move": xr.ActionType.VECTOR2F_INPUT,
            "turn": xr.ActionType.VECTOR2F_INPUT,
            "trigger": xr.ActionType.BOOLEAN_INPUT,
            "menu": xr.ActionType.BOOLEAN_INPUT,
            "grip": xr.ActionType.POSE_INPUT,
        }
        for name, kind in kinds.items():
            self._actions[name] = xr.create_action(
                self._action_set,
                xr.ActionCreateInfo(
                    action_name=name,
                    action_type=kind,
                    subaction_paths=self._hands,
                    localized_action_name=name,
                ),
            )
        for profile, table in BINDINGS.items():
            suggested = [
                xr.ActionSuggestedBinding(action=self._actions[a], binding=path(p))
                for a, paths in table.items()
                for p in paths
            ]
            try:
                xr.suggest_interaction_profile_bindings(
                    self.instance,
                    xr.InteractionProfileSuggestedBinding(
                        interaction_profile=path(profile), suggested_bindings=suggested
                    ),
                )
            except xr.PathUnsupportedError:
                continue  # a runtime may not know every profile; the others still bind
        xr.attach_session_action_sets(
            self.session, xr.SessionActionSetsAttachInfo(action_sets=[self._action_set])
        )
        self._grip_spaces = [
            xr.create_action_space(
                self.session,
                xr.ActionSpaceCreateInfo(
                    action=self._actions["grip"], subaction_path=hand, pose_in_action_space=xr.Posef()
                ),
            )
            for hand in self._hands
        ]

    # -- XrPort ----------------------------------------------------------------------------

    @_lost_guard
    def poll_events(self) -> list[XrEvent]:
        xr = self.xr
        out: list[XrEvent] = []
        while True:
            try:
                buf = xr.poll_event(self.instance)
            except xr.EventUnavailable:
                return out
            kind = xr.StructureType(buf.type)
            if kind == xr.StructureType.EVENT_DATA_SESSION_STATE_CHANGED:
                ev = ctypes.cast(ctypes.byref(buf), ctypes.POINTER(xr.EventDataSessionStateChanged)).contents
                state = ev.state
                out.append(
                    StateChanged(
                        SessionState(state.value if isinstance(state, xr.SessionState) else int(state))
                    )
                )
            elif kind == xr.StructureType.EVENT_DATA_INSTANCE_LOSS_PENDING:
                out.append(InstanceLossPending())

    @_lost_guard
    def begin_session(self) -> None:
        xr = self.xr
        xr.begin_session(
            self.session,
            xr.SessionBeginInfo(primary_view_configuration_type=xr.ViewConfigurationType.PRIMARY_STEREO),
        )

    @_lost_guard
    def end_session(self) -> None:
        self.xr.end_session(self.session)

    @_lost_guard
    def request_exit(self) -> None:
        self.xr.request_exit_session(self.session)

    @_lost_guard
    def wait_frame(self) -> XrFrame:
        state = self.xr.wait_frame(self.session, self.xr.FrameWaitInfo())
        self._time = int(state.predicted_display_time)
        predicted = int(state.predicted_display_period) * 1e-9
        return XrFrame(
            display_time=self._time * 1e-9,
            period=1.0 / self.refresh_hz if self.refresh_hz else predicted,
            should_render=bool(state.should_render),
        )

    @_lost_guard
    def begin_frame(self) -> None:
        self.xr.begin_frame(self.session, self.xr.FrameBeginInfo())

    def _pose(self, p: Any) -> Pose:
        return Pose(
            position=np.array([p.position.x, p.position.y + self._height_offset, p.position.z]),
            orientation=(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w),
        )

    @_lost_guard
    def locate_head(self, display_time: float) -> Pose | None:
        xr = self.xr
        loc = xr.locate_space(self.view_space, self.space, self._time)
        ok = xr.SpaceLocationFlags.POSITION_VALID_BIT | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT
        return self._pose(loc.pose) if (loc.location_flags & ok) == ok else None

    @_lost_guard
    def locate_hands(self, display_time: float) -> list[Pose | None]:
        """Each hand's grip pose (left, right) in the reference space at the frame's predicted time,
        None where the runtime does not give both its position and orientation as valid (a controller
        off, out of tracking, or the session not focused). Call after :meth:`sync_controls`: action
        spaces follow the actions' last sync."""
        xr = self.xr
        ok = xr.SpaceLocationFlags.POSITION_VALID_BIT | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT
        out: list[Pose | None] = []
        for space in self._grip_spaces:
            loc = xr.locate_space(space, self.space, self._time)
            out.append(self._pose(loc.pose) if (loc.location_flags & ok) == ok else None)
        return out

    @_lost_guard
    def locate_views(self, display_time: float) -> list[ViewLocation]:
        xr = self.xr
        state, views = xr.locate_views(
            self.session,
            xr.ViewLocateInfo(
                view_configuration_type=xr.ViewConfigurationType.PRIMARY_STEREO,
                display_time=self._time,
                space=self.space,
            ),
        )
        ok = xr.ViewStateFlags.POSITION_VALID_BIT | xr.ViewStateFlags.ORIENTATION_VALID_BIT
        if (state.view_state_flags & ok) != ok:
            return []
        self._xr_views = list(views)
        return [
            ViewLocation(
                pose=self._pose(v.pose),
                fov=(v.fov.angle_left, v.fov.angle_right, v.fov.angle_up, v.fov.angle_down),
            )
            for v in views
        ]

    @_lost_guard
    def sync_controls(self, *, focused: bool) -> Controls:
        xr = self.xr
        if not focused:
            return Controls()
        xr.sync_actions(
            self.session,
            xr.ActionsSyncInfo(
                active_action_sets=[
                    xr.ActiveActionSet(action_set=self._action_set, subaction_path=xr.NULL_PATH)
                ]
            ),
        )

        def vec(name: str, hand: int) -> tuple[float, float]:
            s = xr.get_action_state_vector2f(
                self.session,
                xr.ActionStateGetInfo(action=self._actions[name], subaction_path=self._hands[hand]),
            )
            return (s.current_state.x, s.current_state.y) if s.is_active else (0.0, 0.0)

        def pressed(name: str) -> bool:
            s = xr.get_action_state_boolean(self.session, xr.ActionStateGetInfo(action=self._actions[name]))
            now = bool(s.is_active and s.current_state)
            edge = now and not self._prev_buttons[name]
            self._prev_buttons[name] = now
            return edge

        def hand_down(name: str) -> int:
            """Which hand holds ``name`` down (right first): 0 left, 1 right, -1 neither says so."""
            for k in (1, 0):
                info = xr.ActionStateGetInfo(action=self._actions[name], subaction_path=self._hands[k])
                s = xr.get_action_state_boolean(self.session, info)
                if s.is_active and s.current_state:
                    return k
            return -1

        trigger = pressed("trigger")
        return Controls(
            move=vec("move", 0), turn=vec("turn", 1)[0], trigger=trigger, menu=pressed("menu"),
            trigger_hand=hand_down("trigger") if trigger else -1,
        )

    @_lost_guard
    def render_eye(self, index: int, draw: Callable[[object, tuple[int, int, int, int]], None]) -> None:
        xr = self.xr
        sc = self.swapchains[index]
        k = xr.acquire_swapchain_image(sc, xr.SwapchainImageAcquireInfo())
        xr.wait_swapchain_image(sc, xr.SwapchainImageWaitInfo(timeout=xr.INFINITE_DURATION))
        _, _, fbo = self.targets[index][k]
        try:
            draw(fbo, (0, 0, *self.sizes[index]))
            if self.capture is not None and index not in self._captured:
                self._save_capture(index, fbo)
        finally:
            xr.release_swapchain_image(sc, xr.SwapchainImageReleaseInfo())

    def _save_capture(self, index: int, fbo: Any) -> None:
        """Eye ``index`` as drawn into its swapchain image, and the views' poses (PEDVR_XR_CAPTURE)."""
        import json

        from PIL import Image

        assert self.capture is not None
        self.capture.mkdir(parents=True, exist_ok=True)
        w, h = self.sizes[index]
        rgb = np.frombuffer(fbo.read(viewport=(0, 0, w, h), components=3), np.uint8).reshape(h, w, 3)
        Image.fromarray(rgb[::-1]).save(self.capture / f"eye{index}.png")
        self._captured.add(index)
        views = [
            {"position": [v.pose.position.x, v.pose.position.y, v.pose.position.z],
             "orientation": [v.pose.orientation.x, v.pose.orientation.y, v.pose.orientation.z,
                             v.pose.orientation.w],
             "fov": [v.fov.angle_left, v.fov.angle_right, v.fov.angle_up, v.fov.angle_down],
             "size": list(self.sizes[i]), "space": self.space_kind}
            for i, v in enumerate(self._xr_views)
        ]
        (self.capture / "views.json").write_text(json.dumps(views, indent=1) + "\n")

    @_lost_guard
    def end_frame(self, *, display_time: float, views: list[ViewLocation] | None) -> None:
        xr = self.xr
        layers = []
        if views:
            proj_views = [
                xr.CompositionLayerProjectionView(
                    pose=v.pose,
                    fov=v.fov,
                    sub_image=xr.SwapchainSubImage(
                        swapchain=self.swapchains[i],
                        image_rect=xr.Rect2Di(offset=xr.Offset2Di(0, 0), extent=xr.Extent2Di(*self.sizes[i])),
                    ),
                )
                for i, v in enumerate(self._xr_views)
            ]
            layer = xr.CompositionLayerProjection(space=self.space, views=proj_views)
            self._layer = layer  # alive until xrEndFrame returns
            layers.append(ctypes.byref(layer))
        xr.end_frame(
            self.session,
            xr.FrameEndInfo(
                display_time=self._time, environment_blend_mode=xr.EnvironmentBlendMode.OPAQUE, layers=layers
            ),
        )

    def idle_wait(self) -> None:
        import time

        time.sleep(0.01)  # session not running: poll events at 100 Hz without spinning

    @contextlib.contextmanager
    def offscreen_target(self) -> Iterator[Any]:
        """A framebuffer like the first eye's swapchain images (same format, size, depth buffer),
        for drawing a frame before the session runs (:mod:`pedvr.prepare`); released on exit."""
        w, h = self.sizes[0]
        tex = self.ctx.texture((w, h), 4, internal_format=self._format)
        depth = self.ctx.depth_renderbuffer((w, h))
        fbo = self.ctx.framebuffer(color_attachments=[tex], depth_attachment=depth)
        try:
            yield fbo
        finally:
            fbo.release()
            depth.release()
            tex.release()

    @property
    def renderer_name(self) -> str:
        """The OpenGL renderer drawing the eyes (e.g. ``llvmpipe (LLVM 19.1.7, 256 bits)``)."""
        return str(self.ctx.info.get("GL_RENDERER", "unknown")) if self.ctx is not None else "unknown"

    def runtime_facts(self) -> dict[str, Any]:
        """What a methods section needs about the runtime and headset (``pedvr xr check``; a study
        session stores the same with its records). The bound interaction profiles are known only
        once the session has been focused and the actions synced; before that they are None."""
        xr = self.xr
        props = xr.get_instance_properties(self.instance)
        eye = None
        if "XR_EXT_eye_gaze_interaction" in self.enabled:
            eye = xr.SystemEyeGazeInteractionPropertiesEXT()
        system = xr.SystemProperties(next=eye) if eye is not None else xr.SystemProperties()
        get = xr.raw_functions.xrGetSystemProperties
        result = xr.check_result(xr.Result(get(self.instance, self.system, ctypes.byref(system))))
        if result.is_exception():
            raise result
        views = xr.enumerate_view_configuration_views(
            self.instance, self.system, xr.ViewConfigurationType.PRIMARY_STEREO
        )
        spaces = [_space_name(xr, s) for s in xr.enumerate_reference_spaces(self.session)]
        bounds = None
        if "STAGE" in spaces:
            try:
                b = xr.get_reference_space_bounds_rect(self.session, xr.ReferenceSpaceType.STAGE)
                bounds = [round(float(b.width), 3), round(float(b.height), 3)] if b.width > 0 else None
            except xr.XrException:  # SPACE_BOUNDS_UNAVAILABLE is a success code some wrappers raise
                bounds = None
        rates = None
        if "XR_FB_display_refresh_rate" in self.enabled:
            rates = [round(_float(r), 3) for r in xr.enumerate_display_refresh_rates_fb(self.session)]
        return {
            "runtime": _text(props.runtime_name),
            "runtime_version": str(xr.Version(props.runtime_version)),
            "system": _text(system.system_name),
            "vendor_id": int(system.vendor_id),
            "orientation_tracking": bool(system.tracking_properties.orientation_tracking),
            "position_tracking": bool(system.tracking_properties.position_tracking),
            "view_configuration": "PRIMARY_STEREO",
            "recommended_eye_size": [
                [int(v.recommended_image_rect_width), int(v.recommended_image_rect_height)] for v in views
            ],
            "refresh_hz": self.refresh_hz,
            "refresh_rates_hz": rates,
            "reference_spaces": spaces,
            "space": self.space_kind,
            "play_area_m": bounds,
            "interaction_profiles": self.interaction_profiles(),
            "eye_gaze_interaction": {
                "offered": "XR_EXT_eye_gaze_interaction" in self.extensions,
                "supported": bool(eye.supports_eye_gaze_interaction) if eye is not None else False,
            },
            "graphics": {"context": self.context_kind, "renderer": self.renderer_name,
                         "srgb_swapchains": self.srgb},
            "extensions_enabled": list(self.enabled),
        }

    def interaction_profiles(self) -> dict[str, str | None]:
        """The interaction profile the runtime bound per hand (None where nothing is bound yet)."""
        xr = self.xr
        out: dict[str, str | None] = {}
        for name, hand in zip(("left", "right"), self._hands, strict=True):
            state = xr.get_current_interaction_profile(self.session, hand)
            path = int(state.interaction_profile)
            out[name] = xr.path_to_string(self.instance, state.interaction_profile) if path else None
        return out

    def close(self) -> None:
        """Release everything; after a lost runtime the destroy calls may fail, which is expected."""
        xr = self.xr

        def quiet(call: Callable[..., Any], *args: Any) -> None:
            try:
                call(*args)
            except xr.XrException:
                pass

        for eye in self.targets:
            for tex, depth, fbo in eye:
                fbo.release()
                depth.release()
                tex.release()
        for sc in self.swapchains:
            quiet(xr.destroy_swapchain, sc)
        self.swapchains, self.targets = [], []
        for space in self._grip_spaces:
            quiet(xr.destroy_space, space)
        self._grip_spaces = []
        if self.session is not None:
            quiet(xr.destroy_session, self.session)
            self.session = None
        if self.instance is not None:
            quiet(xr.destroy_instance, self.instance)
            self.instance = None
        if self.window is not None:
            import glfw

            glfw.destroy_window(self.window)
            self.window = None
        self._release_egl()

    def _release_egl(self) -> None:
        if self._egl is not None:
            egl, display, context = self._egl
            egl.lib.eglMakeCurrent(display, None, None, None)
            egl.lib.eglDestroyContext(display, context)
            self._egl = None


# EGL 1.5 enumerants (Khronos eglplatform / egl.h).
EGL_NONE = 0x3038
EGL_SURFACE_TYPE = 0x3033
EGL_PBUFFER_BIT = 0x0001
EGL_RENDERABLE_TYPE = 0x3040
EGL_OPENGL_BIT = 0x0008
EGL_RED_SIZE, EGL_GREEN_SIZE, EGL_BLUE_SIZE, EGL_DEPTH_SIZE = 0x3024, 0x3023, 0x3022, 0x3025
EGL_OPENGL_API = 0x30A2
EGL_CONTEXT_MAJOR_VERSION = 0x3098
EGL_CONTEXT_MINOR_VERSION = 0x30FB
EGL_CONTEXT_OPENGL_PROFILE_MASK = 0x30FD
EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT = 0x0001
EGL_EXTENSIONS = 0x3055
EGL_PLATFORM_SURFACELESS_MESA = 0x31DD


class _Egl:
    """The few libEGL entry points :meth:`OpenXRPort._egl_context` needs, typed for ctypes."""

    def __init__(self) -> None:
        lib = ctypes.CDLL("libEGL.so.1")
        p, i, u = ctypes.c_void_p, ctypes.c_int, ctypes.c_uint
        for name, res, args in (
            ("eglQueryString", ctypes.c_char_p, [p, i]),
            ("eglGetPlatformDisplay", p, [u, p, p]),
            ("eglGetDisplay", p, [p]),
            ("eglInitialize", u, [p, ctypes.POINTER(i), ctypes.POINTER(i)]),
            ("eglChooseConfig", u, [p, ctypes.POINTER(i), ctypes.POINTER(p), i, ctypes.POINTER(i)]),
            ("eglBindAPI", u, [u]),
            ("eglCreateContext", p, [p, p, p, ctypes.POINTER(i)]),
            ("eglMakeCurrent", u, [p, p, p, p]),
            ("eglDestroyContext", u, [p, p]),
            ("eglTerminate", u, [p]),
            ("eglGetError", i, []),
        ):
            f = getattr(lib, name)
            f.restype, f.argtypes = res, args
        self.lib = lib

    def display(self) -> int | None:
        client = (self.lib.eglQueryString(None, EGL_EXTENSIONS) or b"").decode().split()
        if "EGL_MESA_platform_surfaceless" in client:
            return self.lib.eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, None, None)
        return self.lib.eglGetDisplay(None)


def _space_name(xr: Any, space: Any) -> str:
    value = int(space.value) if isinstance(space, enum.Enum) else int(space)
    try:
        return xr.ReferenceSpaceType(value).name
    except ValueError:
        return f"0x{value:x}"
