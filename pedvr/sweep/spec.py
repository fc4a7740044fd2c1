"""Sweep specs: a TOML file naming scenes, parameters and seeds, expanded into tasks.

The smallest spec::

    [sweep]
    name = "responsibility"
    scenes = ["headon_corridor"]      # shipped names, paths or globs (relative to this file)
    duration = 6.0                    # simulated seconds per run
    seeds = [1, 2, 3, 4]              # or a range: seeds = { from = 1, count = 200 }
    [sweep.grid]                      # the cartesian product of these
    responsibility = [0.0, 0.5, 1.0]  # any run option or dotted scene key

Every key of ``[sweep]``:

``name`` (required): names the default output folder and the study store.
``scenes``: shipped scene names, ``.toml`` scenes, SteerSuite ``.xml`` cases, or
globs such as ``"../shared/benchmarks/steersuite/*.xml"``; paths and globs are
relative to the spec file. ``duration`` (s, required unless swept): simulated
time per run. ``seeds`` (required): a list of integers or ``{from, count}``.
``keep``: ``"metrics"`` (default: one table row per run) or ``"recordings"``
(also each run's trajectory ``.npz``). ``steerbench``: add SteerBench scores
(:mod:`pedvr.sweep.steerbench`) to each row; default on for SteerSuite cases
and off for pedvr scenes.

Parameters are the run options ``condition`` (``decoupled``, ``pedvr``,
``pedvr+g``; default ``pedvr`` as in ``pedvr run``), ``responsibility`` (ρ in
[0, 1]; default the scene's), ``personal_space`` (m in [0, 2]; default the
scene's ``steering.personal_space``), ``user_walk`` (``straight`` or
``reactive``; default the scene's ``user.walk``), ``duration`` — the options of
``pedvr run`` by the same names, which apply to SteerSuite cases too — and any
dotted scene key
(``steering.time_horizon``, ``agents.spawns[0].count``, ``gaze.distance``),
which is written into the scene's TOML data *before* the scene loader
validates it, so a bad value gets the loader's own message, prefixed with the
spec key that set it. They are given three ways, which combine:
``[sweep.set]`` one value each, for every run; ``[sweep.grid]`` a list each,
crossed (the cartesian product); ``[[sweep.cases]]`` explicit combinations,
each crossed with the grid. A key may be given only one way; an empty
``[sweep.grid]`` is an error (it would run the scenes once each, silently).
The tasks are scenes × cases × grid × seeds.

Choices where the issue is open: dotted overrides apply to TOML scenes only
(a SteerSuite case is XML and has no TOML keys; a spec that sets one on a case
is an error naming both). ``personal_space`` and ``steering.personal_space``
set the same margin (the run option wins, as ``pedvr run --personal-space``
does over the scene).

``[sweep.participants]`` instead of ``scenes``: ``protocol`` (a study protocol
file), ``count`` simulated participants numbered from ``first`` (default 1;
ids ``SIM01``...), ``max_trial_seconds`` (optional cap on every trial, as
``pedvr study run --max-trial-seconds``). Their answers go into one study
store per sweep (:mod:`pedvr.sweep.participants`).

Every problem in a spec is reported at once, one line each, as
``spec.toml: sweep.grid.responsibility[2] = 1.5: must be in [0, 1]``.
"""

from __future__ import annotations

import glob
import hashlib
import itertools
import json
import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

from pedvr.errors import PedvrError, SceneError
from pedvr.scene.config import CONDITIONS, USER_WALKS, SceneConfig
from pedvr.sweep.errors import SweepSpecError
from pedvr.validation import MISSING, Checker, fmt, is_num

RUN_OPTIONS = ("condition", "duration", "responsibility", "personal_space", "user_walk")
KEEP = ("metrics", "recordings")
_SWEEP_KEYS = (
    "name",
    "scenes",
    "duration",
    "seeds",
    "keep",
    "steerbench",
    "set",
    "grid",
    "cases",
    "participants",
)
_INDEX = re.compile(r"^(?P<name>[^\[\]]+)(?P<idx>(\[\d+\])*)$")


def pedvr_version() -> str:
    """The pedvr version that goes into every task's key: ``pedvr.__version__``, the code that
    runs (an editable install's metadata keeps the version it was installed with)."""
    from pedvr import __version__

    return __version__


def _digest(obj: object, n: int = 16) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()).hexdigest()[:n]


# -- what a worker receives ------------------------------------------------------------------


@dataclass(frozen=True)
class SceneInput:
    """A scene as content, not as a path, so a worker on another machine can build it.

    ``kind`` ``toml``: ``data`` is the parsed TOML with the run's overrides
    written in (validated once when the spec was loaded); ``xml``: ``xml`` is
    the SteerSuite case's bytes, expanded per seed (its ``<random>`` elements
    draw from the run's seed). ``content_hash`` is the file's (as in
    recordings' meta) or, with overrides, a hash of the file's and the overrides.
    """

    kind: Literal["toml", "xml"]
    source: str
    content_hash: str
    data: dict[str, Any] | None = None
    xml: bytes | None = None

    def load(self, seed: int) -> SceneConfig:
        from pedvr.scene.loader import parse_scene

        if self.kind == "toml":
            assert self.data is not None
            return parse_scene(self.data, source=self.source, content_hash=self.content_hash)
        import tempfile

        from pedvr.scene.steersuite import load_steersuite

        assert self.xml is not None
        with tempfile.TemporaryDirectory(prefix="pedvr-sweep-") as tmp:
            path = Path(tmp) / Path(self.source).name  # the case is named after its file
            path.write_bytes(self.xml)
            return replace(load_steersuite(path, seed=seed), source=self.source)


@dataclass(frozen=True)
class RunTask:
    """One headless run: a scene with its parameters, a seed, a duration.

    ``key`` is stable: a hash of the scene's name and content (overrides included), the
    run options, the seed, what is kept, and the pedvr version. ``params``
    holds every parameter the spec gave (set, grid or case) as it was given.
    """

    key: str
    scene: SceneInput
    scene_name: str
    seed: int
    duration: float
    condition: str
    responsibility: float | None
    params: tuple[tuple[str, Any], ...]
    keep_recording: bool
    steerbench: bool
    version: str
    personal_space: float | None = None
    user_walk: str | None = None

    def columns(self) -> dict[str, Any]:
        """The row's leading columns: identity, scene, seed and one column per parameter."""
        out: dict[str, Any] = {
            "run_key": self.key,
            "scene": self.scene_name,
            "scene_source": self.scene.source,
            "seed": self.seed,
            "duration": self.duration,
        }
        for k, v in self.params:
            out[k] = v if v is None or isinstance(v, bool | int | float | str) else json.dumps(v)
        out["pedvr_version"] = self.version
        return out

    def describe(self) -> str:
        opts = ", ".join(f"{k}={v}" for k, v in self.params if k != "duration")
        return f"{self.scene_name} seed {self.seed}" + (f" ({opts})" if opts else "")


@dataclass(frozen=True)
class ParticipantTask:
    """One simulated participant through a study protocol (``pedvr study run --simulated``)."""

    key: str
    protocol: str
    participant: str
    number: int
    max_trial_s: float | None
    version: str

    def columns(self) -> dict[str, Any]:
        return {
            "run_key": self.key,
            "participant": self.participant,
            "number": self.number,
            "protocol": self.protocol,
            "max_trial_seconds": self.max_trial_s,
            "pedvr_version": self.version,
        }

    def describe(self) -> str:
        return f"participant {self.participant}"


Task = RunTask | ParticipantTask


@dataclass(frozen=True)
class SweepSpec:
    """A validated, expanded sweep: its tasks in submission order.

    ``parameters`` are the names of the parameter columns (set, grid and case
    keys, and ``duration``); ``swept`` those that take more than one value.
    ``study`` is the protocol's study name for a participants sweep (its store
    is ``<study>.sqlite`` in the output folder), else None.
    """

    name: str
    source: str
    text: str
    tasks: tuple[Task, ...]
    parameters: tuple[str, ...] = ()
    swept: tuple[str, ...] = ()
    study: str | None = None
    scenes: tuple[str, ...] = ()


# -- loading ---------------------------------------------------------------------------------


def load_spec(path: str | Path) -> SweepSpec:
    """Read, validate and expand a sweep spec; raise one SweepSpecError listing every problem."""
    p = Path(path)
    shown = str(path)
    if not p.is_file():
        raise SweepSpecError([f"{shown}: no such sweep spec"])
    text = p.read_bytes().decode("utf-8", errors="replace")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SweepSpecError([f"{shown}: not valid TOML: {exc}"]) from None
    return parse_spec(data, source=shown, base_dir=p.resolve().parent, text=text)


@dataclass
class _Value:
    value: Any
    where: str  # the spec key that gave it, e.g. sweep.grid.responsibility[2]


def _leaves(c: Checker, d: dict[str, Any], path: str, *, lists: bool) -> dict[str, tuple[Any, str]]:
    """Flatten nested tables into dotted keys (TOML's ``a.b = 1`` is a nested table).

    With ``lists``, a leaf must be a non-empty array of values (a grid axis).
    """
    out: dict[str, tuple[Any, str]] = {}
    for k, v in d.items():
        key, where = (k, f"{path}.{k}")
        if isinstance(v, dict):
            for kk, (vv, ww) in _leaves(c, v, where, lists=lists).items():
                out[f"{key}.{kk}"] = (vv, ww)
        elif lists and (not isinstance(v, list) or not v):
            c.bad(where, v, "expected a non-empty array of values to sweep")
        else:
            out[key] = (v, where)
    return out


def _has_leaves(d: dict[str, Any]) -> bool:
    """Whether a table holds any value that is not a (possibly nested) empty table."""
    return any(not isinstance(v, dict) or _has_leaves(v) for v in d.values())


def _check_key(c: Checker, key: str, value: Any, where: str) -> bool:
    """A parameter's name: a run option or a dotted scene key; reported once per key (not per value)."""
    if key == "seed" or key == "seeds":
        c.bad(where, value, "seeds are given by sweep.seeds")
        return False
    if key not in RUN_OPTIONS and "." not in key:
        c.bad(
            where,
            value,
            f"unknown parameter; run options are {', '.join(RUN_OPTIONS)}, and scene keys "
            "are dotted (steering.time_horizon, agents.spawns[0].count)",
        )
        return False
    return True


def _check_option(c: Checker, key: str, value: Any, where: str) -> bool:
    """One value of a parameter whose name :func:`_check_key` accepted; True when usable."""
    if key == "condition":
        if value not in CONDITIONS:
            c.bad(where, value, f"expected one of {', '.join(repr(x) for x in CONDITIONS)}")
            return False
    elif key == "responsibility":
        if not is_num(value) or not 0.0 <= float(value) <= 1.0:
            c.bad(where, value, "expected a number in [0, 1]")
            return False
    elif key == "duration":
        if not is_num(value) or float(value) <= 0:
            c.bad(where, value, "expected a number > 0 (simulated seconds)")
            return False
    elif key == "personal_space":
        if not is_num(value) or not 0.0 <= float(value) <= 2.0:
            c.bad(where, value, "expected a number in [0, 2] (metres agents keep from the user)")
            return False
    elif key == "user_walk":
        if value not in USER_WALKS:
            c.bad(where, value, f"expected one of {', '.join(repr(x) for x in USER_WALKS)}")
            return False
    return True


def parse_spec(data: dict[str, Any], *, source: str, base_dir: Path, text: str = "") -> SweepSpec:
    """Validate a parsed spec and expand it into tasks (see the module docstring)."""
    c = Checker(source)
    c.known(data, "", ("sweep",))
    sw = c.table(data, "sweep", "sweep", required=True) or {}
    c.known(sw, "sweep", _SWEEP_KEYS)
    name = c.string(sw, "name", "sweep.name")
    if name is not None and not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name):
        c.bad("sweep.name", name, "expected letters, digits, '_', '-' or '.' (it names a folder)")
        name = None
    version = pedvr_version()

    if "participants" in sw:
        for k in ("scenes", "duration", "seeds", "set", "grid", "cases", "keep", "steerbench"):
            if k in sw:
                c.bad(f"sweep.{k}", sw[k], "a participants sweep runs a protocol; it takes no scene keys")
        tasks_p, study = _participants(c, sw, base_dir, version)
        if c.problems:
            raise SweepSpecError(c.problems)
        assert name is not None
        return SweepSpec(name=name, source=source, text=text, tasks=tuple(tasks_p), study=study)

    scenes = _scenes(c, sw, base_dir)
    seeds = _seeds(c, sw)
    keep = c.string(sw, "keep", "sweep.keep", required=False, default="metrics", choices=KEEP)
    steerbench = sw.get("steerbench", MISSING)
    if steerbench is not MISSING and not isinstance(steerbench, bool):
        c.bad("sweep.steerbench", steerbench, "expected true or false")
        steerbench = MISSING

    fixed = _leaves(c, c.table(sw, "set", "sweep.set", required=False) or {}, "sweep.set", lists=False)
    grid_table = c.table(sw, "grid", "sweep.grid", required=False)
    grid = _leaves(c, grid_table or {}, "sweep.grid", lists=True)
    if grid_table is not None and not _has_leaves(grid_table):
        c.bad(
            "sweep.grid",
            grid_table,
            "empty: give each parameter to sweep a list of values, or leave [sweep.grid] out",
        )
    cases_raw = c.tables(sw, "cases", "sweep.cases", required=False)
    cases = [_leaves(c, case, f"sweep.cases[{i}]", lists=False) for i, case in enumerate(cases_raw)]
    case_keys = sorted({k for case in cases for k in case})
    for k in grid:
        if k in fixed:
            c.bad(grid[k][1], grid[k][0], f"also given in sweep.set ({fixed[k][1]}); give a key one way")
        if k in case_keys:
            c.bad(grid[k][1], grid[k][0], "also given in sweep.cases; give a key one way")
    for k in case_keys:
        if k in fixed:
            c.bad(fixed[k][1], fixed[k][0], "also given in sweep.cases; give a key one way")

    # Every parameter's name once where it was written, then each of its values.
    ok = True
    for k, (v, where) in fixed.items():
        ok &= _check_key(c, k, v, where) and _check_option(c, k, v, where)
    for k, (vs, where) in grid.items():
        if not _check_key(c, k, vs, where):
            ok = False
        elif isinstance(vs, list):
            for i, v in enumerate(vs):
                ok &= _check_option(c, k, v, f"{where}[{i}]")
    for case in cases:
        for k, (v, where) in case.items():
            ok &= _check_key(c, k, v, where) and _check_option(c, k, v, where)

    swept_duration = "duration" in grid or "duration" in case_keys
    duration = None
    if "duration" in sw and ("duration" in fixed or swept_duration):
        c.bad("sweep.duration", sw["duration"], "duration is also given as a parameter; give it one way")
    elif "duration" in fixed:
        pass
    elif not swept_duration:
        duration = c.number(
            sw, "duration", "sweep.duration", check=lambda x: x > 0, expect="> 0 (simulated seconds per run)"
        )
    if c.problems or not ok:
        raise SweepSpecError(c.problems)

    # The combinations: cases × grid, each key with the spec key that set it.
    axes = [[(k, _Value(v, f"{where}[{i}]")) for i, v in enumerate(vs)] for k, (vs, where) in grid.items()]
    combos: list[dict[str, _Value]] = []
    for case in cases or [{}]:
        for point in itertools.product(*axes):
            combo = {k: _Value(v, w) for k, (v, w) in fixed.items()}
            combo.update({k: _Value(v, w) for k, (v, w) in case.items()})
            combo.update(dict(point))
            if duration is not None:
                combo.setdefault("duration", _Value(duration, "sweep.duration"))
            combos.append(combo)
    missing_duration = (
        [i for i, cb in enumerate(cases) if "duration" not in cb]
        if swept_duration and "duration" not in grid
        else []
    )
    for i in missing_duration:
        c.bad(
            f"sweep.cases[{i}]",
            "{...}",
            "has no duration, and other cases do: give every case one, or set sweep.duration",
        )
    if c.problems:
        raise SweepSpecError(c.problems)

    assert name is not None and keep is not None
    tasks: list[Task] = []
    for si, (shown, path) in enumerate(scenes):
        kind: Literal["toml", "xml"] = "xml" if path.suffix.lower() == ".xml" else "toml"
        raw = path.read_bytes()
        file_hash = hashlib.sha256(raw).hexdigest()[:16]
        where_scene = f"sweep.scenes[{si}]"
        inputs: dict[str, tuple[SceneInput, str] | None] = {}
        for combo in combos:
            overrides = {k: v for k, v in combo.items() if "." in k}
            okey = _digest({k: v.value for k, v in overrides.items()})
            if okey not in inputs:
                inputs[okey] = _scene_input(
                    c,
                    kind=kind,
                    shown=shown,
                    raw=raw,
                    file_hash=file_hash,
                    overrides=overrides,
                    where_scene=where_scene,
                    first_seed=seeds[0] if seeds else 0,
                )
            got = inputs[okey]
            if got is None or not seeds:
                continue
            scene_input, scene_name = got
            params = tuple(sorted((k, v.value) for k, v in combo.items()))
            opts = {k: v.value for k, v in combo.items()}
            dur = float(opts["duration"])
            cond = str(opts.get("condition", "pedvr"))
            rho = None if "responsibility" not in opts else float(opts["responsibility"])
            margin = None if "personal_space" not in opts else float(opts["personal_space"])
            walk = None if "user_walk" not in opts else str(opts["user_walk"])
            bench = kind == "xml" if steerbench is MISSING else bool(steerbench)
            for seed in seeds:
                key = _digest(
                    {
                        "scene": scene_input.content_hash,
                        "name": scene_name,  # two identical files under two names are two scenes
                        "seed": seed,
                        "duration": dur,
                        "condition": cond,
                        "responsibility": rho,
                        **({"personal_space": margin} if margin is not None else {}),
                        **({"user_walk": walk} if walk is not None else {}),
                        "keep": keep,
                        "steerbench": bench,
                        "version": version,
                    },
                    32,
                )
                tasks.append(
                    RunTask(
                        key=key,
                        scene=scene_input,
                        scene_name=scene_name,
                        seed=seed,
                        duration=dur,
                        condition=cond,
                        responsibility=rho,
                        personal_space=margin,
                        user_walk=walk,
                        params=params,
                        keep_recording=keep == "recordings",
                        steerbench=bench,
                        version=version,
                    )
                )
    if c.problems:
        raise SweepSpecError(list(dict.fromkeys(c.problems)))  # a bad value crossed with other axes: once
    parameters = sorted({k for combo in combos for k in combo})
    swept = [
        k
        for k in parameters
        if len({json.dumps(cb[k].value if k in cb else None, sort_keys=True) for cb in combos}) > 1
    ]
    return SweepSpec(
        name=name,
        source=source,
        text=text,
        tasks=tuple(tasks),
        parameters=tuple(parameters),
        swept=tuple(swept),
        scenes=tuple(s for s, _ in scenes),
    )


def _scenes(c: Checker, sw: dict[str, Any], base_dir: Path) -> list[tuple[str, Path]]:
    from pedvr.scenes import resolve_scene

    names = c.strings(sw, "scenes", "sweep.scenes") or ()
    out: list[tuple[str, Path]] = []
    seen: dict[Path, str] = {}
    for i, v in enumerate(names):
        where = f"sweep.scenes[{i}]"
        found: list[Path]
        # A relative path is read from the spec's folder: a message about one says where it looked.
        relative = "" if Path(v).is_absolute() else f" (paths are relative to the spec file: {base_dir / v})"
        if any(ch in v for ch in "*?["):
            pattern = v if Path(v).is_absolute() else str(base_dir / v)
            found = sorted(Path(x) for x in glob.glob(pattern) if x.lower().endswith((".toml", ".xml")))
            if not found:
                c.bad(where, v, f"the glob matches no .toml or .xml file{relative}")
                continue
        elif v.lower().endswith((".toml", ".xml")):
            found = [Path(v) if Path(v).is_absolute() else base_dir / v]
            if not found[0].is_file():
                c.bad(where, v, f"no such scene file{relative}")
                continue
        else:
            p = resolve_scene(v)
            if not p.is_file():
                c.bad(where, v, "no such shipped scene; `pedvr scene list` names them")
                continue
            found = [p]
        for p in found:
            rp = p.resolve()
            if rp in seen:
                c.bad(where, v, f"{p.name} is already listed ({seen[rp]})")
                continue
            seen[rp] = where
            out.append((_shown(p), rp))
    return out


def _shown(p: Path) -> str:
    """A scene's path as rows and messages show it: relative to the current folder when it can be."""
    try:
        return str(p.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(p.resolve())


def _seeds(c: Checker, sw: dict[str, Any]) -> list[int]:
    v = sw.get("seeds", MISSING)
    if v is MISSING:
        c.bad("sweep.seeds", v, "required: a list of integers, or {from = 1, count = 200}")
        return []
    if isinstance(v, dict):
        c.known(v, "sweep.seeds", ("from", "count"))
        first = c.integer(v, "from", "sweep.seeds.from", check=lambda x: x >= 0, expect=">= 0")
        count = c.integer(v, "count", "sweep.seeds.count", check=lambda x: x >= 1, expect=">= 1")
        return [] if first is None or count is None else list(range(first, first + count))
    if (
        not isinstance(v, list)
        or not v
        or not all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in v)
    ):
        c.bad("sweep.seeds", v, "expected a non-empty list of integers >= 0, or {from = 1, count = 200}")
        return []
    dupes = sorted({x for x in v if v.count(x) > 1})
    if dupes:
        c.bad("sweep.seeds", v, f"seed {dupes[0]} is listed twice")
        return []
    return list(v)


def set_dotted(data: dict[str, Any], key: str, value: Any) -> str | None:
    """Write ``value`` at dotted ``key`` (``a.b[0].c``) into TOML ``data``; the reason when it cannot."""
    parts = key.split(".")
    node: Any = data
    for n, part in enumerate(parts):
        m = _INDEX.match(part)
        if m is None:
            return f"{part!r} is not a key or key[index]"
        name, idx = m.group("name"), [int(x) for x in re.findall(r"\[(\d+)\]", m.group("idx"))]
        last = n == len(parts) - 1
        if not isinstance(node, dict):
            return f"{'.'.join(parts[:n])} is not a table in the scene"
        if last and not idx:
            node[name] = value
            return None
        if idx:
            if name not in node:
                return f"the scene has no {'.'.join(parts[:n] + [name])}"
            node = node[name]
            for j, i in enumerate(idx):
                if not isinstance(node, list) or i >= len(node):
                    size = len(node) if isinstance(node, list) else 0
                    return (
                        f"{'.'.join(parts[:n] + [name])}{''.join(f'[{x}]' for x in idx[: j + 1])} is "
                        f"out of range (the scene has {size})"
                    )
                if last and j == len(idx) - 1:
                    node[i] = value
                    return None
                node = node[i]
        else:
            node = node.setdefault(name, {})
    return None


def _scene_input(
    c: Checker,
    *,
    kind: Literal["toml", "xml"],
    shown: str,
    raw: bytes,
    file_hash: str,
    overrides: dict[str, _Value],
    where_scene: str,
    first_seed: int,
) -> tuple[SceneInput, str] | None:
    """Validate one scene with one combination of overrides; its input for workers and its name."""
    import copy

    from pedvr.scene.loader import parse_scene

    if kind == "xml":
        for v in overrides.values():
            c.bad(v.where, v.value, f"scene keys apply to TOML scenes; {shown} is a SteerSuite case")
        if overrides:
            return None
        si = SceneInput(kind="xml", source=shown, content_hash=file_hash, xml=raw)
        try:
            return si, si.load(first_seed).name
        except SceneError as exc:
            for line in exc.problems:
                c.bad(where_scene, shown, f"scene problem: {line}")
            return None
    try:
        base = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        c.bad(where_scene, shown, f"scene problem: not valid TOML: {exc}")
        return None
    data = copy.deepcopy(base)
    for k, v in overrides.items():
        why = set_dotted(data, k, copy.deepcopy(v.value))
        if why is not None:
            c.bad(v.where, v.value, f"cannot apply to {shown}: {why}")
            return None
    content_hash = (
        file_hash
        if not overrides
        else _digest({"file": file_hash, "overrides": {k: v.value for k, v in overrides.items()}})
    )
    try:
        cfg = parse_scene(data, source=shown, content_hash=content_hash)
    except SceneError as exc:
        if not overrides:
            for line in exc.problems:
                c.bad(where_scene, shown, f"scene problem: {line}")
            return None
        for line in exc.problems:
            key = line[len(shown) + 2 :].split(" = ", 1)[0]
            blame = [
                v
                for k, v in overrides.items()
                if key == k or key.startswith(k + ".") or key.startswith(k + "[")
            ]
            if blame:
                c.bad(blame[0].where, blame[0].value, line)
            else:
                given = ", ".join(f"{v.where} = {fmt(v.value)}" for v in overrides.values())
                c.problems.append(f"{c.source}: {given}: {line}")
        return None
    except PedvrError as exc:  # pragma: no cover - parse_scene raises SceneError for bad data
        c.bad(where_scene, shown, f"scene problem: {exc}")
        return None
    return SceneInput(kind="toml", source=shown, content_hash=content_hash, data=data), cfg.name


def _participants(
    c: Checker, sw: dict[str, Any], base_dir: Path, version: str
) -> tuple[list[ParticipantTask], str | None]:
    p = c.table(sw, "participants", "sweep.participants", required=True) or {}
    c.known(p, "sweep.participants", ("protocol", "count", "first", "max_trial_seconds"))
    proto = c.string(p, "protocol", "sweep.participants.protocol")
    count = c.integer(p, "count", "sweep.participants.count", check=lambda x: x >= 1, expect=">= 1")
    first = c.integer(
        p,
        "first",
        "sweep.participants.first",
        required=False,
        default=1,
        check=lambda x: x >= 1,
        expect=">= 1",
    )
    cap = c.number(
        p,
        "max_trial_seconds",
        "sweep.participants.max_trial_seconds",
        required=False,
        default=None,
        check=lambda x: x > 0,
        expect="> 0 s",
    )
    if proto is None:
        return [], None
    path = Path(proto) if Path(proto).is_absolute() else base_dir / proto
    from pedvr.study.protocol import load_protocol

    try:
        protocol = load_protocol(path, display_path=_shown(path))
    except PedvrError as exc:
        for line in str(exc).splitlines():
            c.bad("sweep.participants.protocol", proto, f"protocol problem: {line}")
        return [], None
    if count is None or first is None:
        return [], None
    width = max(2, len(str(first + count - 1)))
    tasks = []
    for n in range(first, first + count):
        pid = f"SIM{n:0{width}d}"
        key = _digest(
            {"protocol": protocol.content_hash, "participant": pid, "cap": cap, "version": version}, 32
        )
        tasks.append(
            ParticipantTask(
                key=key,
                protocol=str(path.resolve()),
                participant=pid,
                number=n,
                max_trial_s=cap,
                version=version,
            )
        )
    return tasks, protocol.name
