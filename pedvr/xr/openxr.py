"""The thin layer of real pyopenxr calls behind :class:`pedvr.xr.session.XrPort`.

Instance with ``XR_KHR_opengl_enable``; the HMD system; an OpenGL binding
from a hidden glfw window (GLX on X11); the session; a LOCAL_FLOOR reference
space (else STAGE, else LOCAL raised by a standing eye height); one
swapchain per eye, sRGB when offered, its images wrapped as moderngl
textures with a depth buffer each; actions (left stick / trackpad move,
right stick snap turn, trigger, menu, and each hand's grip pose through an
action space located every frame in the reference space) with suggested
bindings for the common controller profiles. All decisions live in :mod:`pedvr.xr.session` and are
tested with a fake port; this module only translates.

Every failure to start is a :class:`~pedvr.errors.BackendUnavailableError`
with one line naming the cause and what to do.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Callable
from typing import Any

import numpy as np

from pedvr.errors import BackendUnavailableError
from pedvr.xr.locomotion import Controls
from pedvr.xr.session import (
    InstanceLossPending,
    Pose,
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
        self.instance = xr.create_instance(
            xr.InstanceCreateInfo(
                application_info=xr.ApplicationInfo(application_name="pedvr", engine_name="pedvr"),
                enabled_extension_names=[xr.KHR_OPENGL_ENABLE_EXTENSION_NAME],
            )
        )
        self.system = xr.get_system(
            self.instance, xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY)
        )
        self._gl_window()
        # xrGetOpenGLGraphicsRequirementsKHR must be called before xrCreateSession.
        get_req = ctypes.cast(
            xr.get_instance_proc_addr(self.instance, "xrGetOpenGLGraphicsRequirementsKHR"),
            xr.PFN_xrGetOpenGLGraphicsRequirementsKHR,
        )
        req = xr.GraphicsRequirementsOpenGLKHR()
        result = xr.check_result(xr.Result(get_req(self.instance, self.system, ctypes.byref(req))))
        if result.is_exception():
            raise result
        # The binding's fields are PyOpenGL GLX types; read them from the current context (as
        # pyopenxr's own GLXGraphicsBinding does) rather than casting glfw's raw handles.
        from OpenGL import GLX

        binding = xr.GraphicsBindingOpenGLXlibKHR(
            x_display=GLX.glXGetCurrentDisplay(),
            glx_drawable=GLX.glXGetCurrentDrawable(),
            glx_context=GLX.glXGetCurrentContext(),
        )
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

    def _gl_window(self) -> None:
        import glfw
        import moderngl

        if not glfw.init():
            raise BackendUnavailableError(
                "cannot start the OpenXR backend: no display for the OpenGL context "
                "(glfw could not initialise); use --backend headless"
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

    def begin_session(self) -> None:
        xr = self.xr
        xr.begin_session(
            self.session,
            xr.SessionBeginInfo(primary_view_configuration_type=xr.ViewConfigurationType.PRIMARY_STEREO),
        )

    def end_session(self) -> None:
        self.xr.end_session(self.session)

    def request_exit(self) -> None:
        self.xr.request_exit_session(self.session)

    def wait_frame(self) -> XrFrame:
        state = self.xr.wait_frame(self.session, self.xr.FrameWaitInfo())
        self._time = int(state.predicted_display_time)
        return XrFrame(
            display_time=self._time * 1e-9,
            period=int(state.predicted_display_period) * 1e-9,
            should_render=bool(state.should_render),
        )

    def begin_frame(self) -> None:
        self.xr.begin_frame(self.session, self.xr.FrameBeginInfo())

    def _pose(self, p: Any) -> Pose:
        return Pose(
            position=np.array([p.position.x, p.position.y + self._height_offset, p.position.z]),
            orientation=(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w),
        )

    def locate_head(self, display_time: float) -> Pose | None:
        xr = self.xr
        loc = xr.locate_space(self.view_space, self.space, self._time)
        ok = xr.SpaceLocationFlags.POSITION_VALID_BIT | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT
        return self._pose(loc.pose) if (loc.location_flags & ok) == ok else None

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

    def render_eye(self, index: int, draw: Callable[[object, tuple[int, int, int, int]], None]) -> None:
        xr = self.xr
        sc = self.swapchains[index]
        k = xr.acquire_swapchain_image(sc, xr.SwapchainImageAcquireInfo())
        xr.wait_swapchain_image(sc, xr.SwapchainImageWaitInfo(timeout=xr.INFINITE_DURATION))
        _, _, fbo = self.targets[index][k]
        try:
            draw(fbo, (0, 0, *self.sizes[index]))
        finally:
            xr.release_swapchain_image(sc, xr.SwapchainImageReleaseInfo())

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

    def close(self) -> None:
        xr = self.xr
        for eye in self.targets:
            for tex, depth, fbo in eye:
                fbo.release()
                depth.release()
                tex.release()
        for sc in self.swapchains:
            xr.destroy_swapchain(sc)
        self.swapchains, self.targets = [], []
        for space in self._grip_spaces:
            xr.destroy_space(space)
        self._grip_spaces = []
        if self.session is not None:
            xr.destroy_session(self.session)
            self.session = None
        if self.instance is not None:
            xr.destroy_instance(self.instance)
            self.instance = None
        if self.window is not None:
            import glfw

            glfw.destroy_window(self.window)
            self.window = None
