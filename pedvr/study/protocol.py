"""Study protocols as data, validated at load, and each participant's plan.

A protocol (``user_study/*.toml``, format in ``user_study/EXPERIMENTER.md``)
is a list of steps: ``instructions``, ``questionnaire``, ``trial`` (one scene
in one condition), ``blocks`` (scenarios presented in counterbalanced order,
each running every condition in counterbalanced order and then a
questionnaire, PedVR §6.4) and ``sweep`` (one scene repeated over parameter
values in random order: the head-on corridor with responsibility 0, 0.25,
0.5, 1.0). Loading collects every problem of the protocol, its
questionnaires and its scenes and raises one :class:`ProtocolError`.

:func:`plan_for` expands a protocol for one participant number into a flat
list of :class:`PlannedStep` — the states of the session state machine.
"""

from __future__ import annotations

import hashlib
import json
import re
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from pedvr.errors import SceneError
from pedvr.scene.config import CONDITIONS
from pedvr.study.counterbalance import (
    left_right_flipped,
    random_order,
    rows_in_square,
    square_row,
    stable_seed,
)
from pedvr.study.errors import ProtocolError
from pedvr.study.questionnaire import Questionnaire, load_questionnaire
from pedvr.validation import MISSING, Checker, is_num

STEP_KINDS = ("instructions", "questionnaire", "trial", "blocks", "sweep")
# Keys of a trial step; a sweep (the corridor's responsibility series) adds "order".
_TRIAL_KEYS = ("id", "kind", "scene", "condition", "time_limit_s", "responsibility", "text",
               "record_trajectories")
ORDERS = ("balanced_latin_square", "random", "fixed")
_ID = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")


@dataclass(frozen=True)
class BlockSpec:
    """One scenario of a ``blocks`` step: every condition, then a questionnaire."""

    id: str
    scene: str  # as written in the protocol: a shipped scene name or a path relative to the protocol
    scene_name: str
    scene_hash: str
    time_limit_s: float
    conditions: tuple[str, ...]
    condition_order: str
    after_block: str | None
    after_each_trial: tuple[str, ...]  # questionnaires after every trial of the block, in this order
    responsibility: float | None


@dataclass(frozen=True)
class DemoCue:
    """A trial's cue (``demonstrate`` key): at ``at_s`` s of the trial, a guide demonstrates ``exhibit``
    to the participant (:func:`pedvr.demonstrator.demonstration.demonstrate_to_user`); ``guide_state``
    (a BFSM state of the scene, or None: any free agent) picks who, the nearest the participant."""

    exhibit: str
    at_s: float
    guide_state: str | None = None


@dataclass(frozen=True)
class StepSpec:
    """One step of the protocol as written."""

    id: str
    kind: str
    text: str = ""
    questionnaire: str | None = None
    optional: bool = False
    scene: str | None = None
    scene_name: str | None = None
    scene_hash: str | None = None
    condition: str | None = None
    time_limit_s: float | None = None
    responsibility: float | None = None
    values: tuple[float, ...] = ()
    order: str = "fixed"
    blocks: tuple[BlockSpec, ...] = ()
    record_trajectories: bool = True
    demonstrations: tuple[DemoCue, ...] = ()


@dataclass(frozen=True)
class Protocol:
    """A validated protocol with its questionnaires loaded."""

    name: str
    title: str
    seed: int
    conditions: tuple[str, ...]
    labels: tuple[str, ...]
    comparisons: tuple[tuple[str, str], ...]
    eye_height_m: float
    steps: tuple[StepSpec, ...]
    questionnaires: dict[str, Questionnaire]
    source: str
    content_hash: str
    base_dir: Path = Path(".")
    participant_sex: str = ""  # "" keeps the scene's [user] sex (door etiquette's Care)
    participant_carrying: str = ""  # "" keeps the scene's [user] carrying

    def scene_path(self, scene: str) -> Path:
        """The file a trial's scene reference names (:func:`scene_path`)."""
        return scene_path(scene, self.base_dir)


@dataclass(frozen=True)
class ShownPair:
    """One pairwise comparison as the participant sees it (PedVR §6.2.4)."""

    comparison: str  # fixed orientation "left/right" by condition names, as in Table 3
    left_condition: str
    right_condition: str
    left_label: str
    right_label: str
    flipped: bool  # True when the fixed right condition is shown on the left


@dataclass(frozen=True)
class TrialSpec:
    """Everything needed to run one trial; stored with the participant's plan.

    ``scene`` is the reference as the protocol writes it (a shipped scene
    name, or a path relative to the protocol file), never an absolute path
    made from it, so a study folder can be moved between sessions;
    ``scene_hash`` is the scene file's content hash, so a scene edited
    between two sessions of one participant is noticed on ``--resume``.
    """

    scene: str
    scene_name: str
    scene_hash: str
    condition: str
    label: str | None
    order: int | None
    responsibility: float | None
    seed: int
    time_limit_s: float
    record_trajectory: bool
    demonstrations: tuple[DemoCue, ...] = ()  # trial steps' ``demonstrate`` cues, by time


@dataclass(frozen=True)
class PlannedStep:
    """One state of a participant's session (instructions, questionnaire or trial)."""

    index: int
    key: str
    kind: str
    title: str
    text: str = ""
    questionnaire: str | None = None
    optional: bool = False
    block: str | None = None
    scenario: str | None = None
    condition: str | None = None
    label: str | None = None
    pairs: tuple[ShownPair, ...] = ()
    trial: TrialSpec | None = None
    design: str | None = None  # trials: "single" (a trial step), "block" (a condition of a scenario), "sweep"
    assignment: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)


# -- loading ---------------------------------------------------------------------------------


def load_protocol(path: str | Path, *, display_path: str | None = None) -> Protocol:
    """Load and validate a protocol, its questionnaires and scenes; one ProtocolError lists all problems."""
    p = Path(path)
    shown = display_path or str(path)
    if not p.is_file():
        raise ProtocolError([f"{shown}: no such protocol file"])
    raw = p.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProtocolError([f"{shown}: not valid TOML: {exc}"]) from None
    return parse_protocol(
        data, source=shown, base_dir=p.resolve().parent, content_hash=hashlib.sha256(raw).hexdigest()[:16]
    )


def parse_protocol(data: dict[str, Any], *, source: str, base_dir: Path, content_hash: str = "") -> Protocol:
    c = Checker(source)
    c.known(data, "", ("study", "steps"))
    s = c.table(data, "study", "study", required=True) or {}
    c.known(
        s,
        "study",
        ("name", "title", "seed", "conditions", "labels", "comparisons", "questionnaire_dir", "eye_height_m",
         "participant_sex", "participant_carrying"),
    )
    name = c.string(s, "name", "study.name")
    if name is not None and not _ID.match(name):
        c.bad("study.name", name, "expected letters, digits, _ . - (it names the database file)")
    title = c.string(s, "title", "study.title", required=False, default=name or "")
    seed = c.integer(s, "seed", "study.seed", check=lambda x: x >= 0, expect=">= 0")
    conditions = c.strings(s, "conditions", "study.conditions", minimum=1)
    if conditions is not None:
        for k, cname in enumerate(conditions):
            if cname not in CONDITIONS:
                c.bad(f"study.conditions[{k}]", cname, f"expected one of {', '.join(CONDITIONS)}")
        if len(set(conditions)) != len(conditions):
            c.bad("study.conditions", list(conditions), "conditions must be distinct")
    labels = c.strings(s, "labels", "study.labels", required=False, default=("A", "B", "C", "D", "E", "F"))
    if labels is not None and conditions is not None and len(labels) < len(conditions):
        c.bad("study.labels", list(labels), f"expected at least {len(conditions)} labels, one per condition")
    comparisons = _comparisons(c, s.get("comparisons", MISSING), conditions)
    eye_height = c.number(
        s,
        "eye_height_m",
        "study.eye_height_m",
        required=False,
        default=1.6,
        check=lambda x: 0.5 <= x <= 2.5,
        expect="in [0.5, 2.5] m",
    )
    # Door etiquette (issue 14): who agents holding a door see in the participant (Care, Huang &
    # Terzopoulos Table 3); "" keeps each scene's [user] sex and carrying.
    from pedvr.scene.config import CARRYING, SEXES

    p_sex = c.string(s, "participant_sex", "study.participant_sex", required=False, default="", choices=SEXES)
    p_carrying = c.string(s, "participant_carrying", "study.participant_carrying", required=False, default="",
                          choices=CARRYING)
    qdir_name = c.string(
        s, "questionnaire_dir", "study.questionnaire_dir", required=False, default="questionnaires"
    )

    qdir = base_dir / (qdir_name or "questionnaires")
    questionnaires: dict[str, Questionnaire] = {}
    steps: list[StepSpec] = []
    seen: set[str] = set()

    def questionnaire(key: str, qid: object, *, kinds: tuple[str, ...] | None = None) -> str | None:
        if not isinstance(qid, str) or not qid:
            c.bad(key, qid, "expected a questionnaire id (a file name in the questionnaire folder)")
            return None
        if qid not in questionnaires:
            f = qdir / f"{qid}.toml"
            if not f.is_file():
                c.bad(key, qid, f"no questionnaire file {f}")
                return None
            try:
                questionnaires[qid] = load_questionnaire(f)
            except ProtocolError as exc:
                c.problems.extend(exc.problems)
                return None
        q = questionnaires[qid]
        if q.id != qid:
            c.bad(
                key, qid, f"{q.source} declares questionnaire.id = {q.id!r}; the id must match the file name"
            )
        if kinds is not None and q.kind not in kinds:
            c.bad(key, qid, f"is a {q.kind} questionnaire; expected {' or '.join(kinds)}")
            return None
        return qid

    def scene(key: str, d: dict[str, Any]) -> tuple[str, str, str] | None:
        v = d.get("scene", MISSING)
        if not isinstance(v, str) or not v:
            c.bad(
                key, v, "required scene: a shipped scene name or a .toml/.xml path relative to the protocol"
            )
            return None
        return _resolve_scene(c, key, v, base_dir)

    raw_steps = c.tables(data, "steps", "steps", required=True)
    for k, st in enumerate(raw_steps):
        path = f"steps[{k}]"
        sid = c.string(st, "id", f"{path}.id")
        if sid is not None and not _ID.match(sid):
            c.bad(f"{path}.id", sid, "expected letters, digits, _ . -")
        if sid is not None and sid in seen:
            c.bad(f"{path}.id", sid, "duplicate step id")
        if sid is not None:
            seen.add(sid)
        kind = c.string(st, "kind", f"{path}.kind", choices=STEP_KINDS)
        if kind is None or sid is None:
            continue
        if kind == "instructions":
            c.known(st, path, ("id", "kind", "text"))
            text = c.string(st, "text", f"{path}.text")
            steps.append(StepSpec(id=sid, kind=kind, text=text or ""))
        elif kind == "questionnaire":
            c.known(st, path, ("id", "kind", "questionnaire", "optional"))
            qid = questionnaire(
                f"{path}.questionnaire", st.get("questionnaire", MISSING), kinds=("ssq", "likert", "form")
            )
            optional = c.boolean(st, "optional", f"{path}.optional", default=False)
            steps.append(StepSpec(id=sid, kind=kind, questionnaire=qid, optional=optional))
        elif kind == "trial":
            c.known(st, path, (*_TRIAL_KEYS, "demonstrate"))
            sc = scene(f"{path}.scene", st)
            cond = c.string(st, "condition", f"{path}.condition", choices=CONDITIONS)
            limit = _limit(c, st, path)
            rho = _rho(c, st, path)
            text = c.string(st, "text", f"{path}.text", required=False, default="")
            rec = c.boolean(st, "record_trajectories", f"{path}.record_trajectories", default=True)
            cues = _demo_cues(c, st, path, scene_path(sc[0], base_dir) if sc is not None else None, limit)
            if sc is not None:
                steps.append(
                    StepSpec(
                        id=sid,
                        kind=kind,
                        scene=sc[0],
                        scene_name=sc[1],
                        scene_hash=sc[2],
                        condition=cond,
                        time_limit_s=limit,
                        responsibility=rho,
                        text=text or "",
                        record_trajectories=rec,
                        demonstrations=cues,
                    )
                )
        elif kind == "sweep":
            c.known(st, path, (*_TRIAL_KEYS, "order"))
            sc = scene(f"{path}.scene", st)
            cond = c.string(st, "condition", f"{path}.condition", choices=CONDITIONS)
            limit = _limit(c, st, path)
            order = c.string(st, "order", f"{path}.order", choices=ORDERS)
            text = c.string(st, "text", f"{path}.text", required=False, default="")
            rec = c.boolean(st, "record_trajectories", f"{path}.record_trajectories", default=True)
            vals = st.get("responsibility", MISSING)
            values: tuple[float, ...] = ()
            if not (isinstance(vals, list) and vals and all(is_num(x) and 0 <= x <= 1 for x in vals)):
                c.bad(
                    f"{path}.responsibility",
                    vals,
                    "required array of shares in [0, 1], e.g. [0, 0.25, 0.5, 1]",
                )
            elif len(set(vals)) != len(vals):
                c.bad(f"{path}.responsibility", vals, "values must be distinct")
            else:
                values = tuple(float(x) for x in vals)
            if sc is not None and values and order is not None:
                steps.append(
                    StepSpec(
                        id=sid,
                        kind=kind,
                        scene=sc[0],
                        scene_name=sc[1],
                        scene_hash=sc[2],
                        condition=cond,
                        time_limit_s=limit,
                        values=values,
                        order=order,
                        text=text or "",
                        record_trajectories=rec,
                    )
                )
        else:
            c.known(st, path, ("id", "kind", "order", "blocks", "text"))
            order = c.string(st, "order", f"{path}.order", choices=ORDERS)
            text = c.string(st, "text", f"{path}.text", required=False, default="")
            blocks: list[BlockSpec] = []
            bseen: set[str] = set()
            for j, b in enumerate(c.tables(st, "blocks", f"{path}.blocks", required=True)):
                bp = f"{path}.blocks[{j}]"
                c.known(
                    b,
                    bp,
                    (
                        "id",
                        "scene",
                        "time_limit_s",
                        "conditions",
                        "condition_order",
                        "after_block",
                        "after_each_trial",
                        "responsibility",
                    ),
                )
                bid = c.string(b, "id", f"{bp}.id")
                if bid is not None and bid in bseen:
                    c.bad(f"{bp}.id", bid, "duplicate block id")
                if bid is not None:
                    bseen.add(bid)
                sc = scene(f"{bp}.scene", b)
                limit = _limit(c, b, bp)
                rho = _rho(c, b, bp)
                conds = c.strings(
                    b, "conditions", f"{bp}.conditions", required=False, default=conditions or ()
                )
                if conds is not None and conditions is not None:
                    for i, cname in enumerate(conds):
                        if cname not in conditions:
                            c.bad(f"{bp}.conditions[{i}]", cname, "not one of study.conditions")
                corder = c.string(b, "condition_order", f"{bp}.condition_order", choices=ORDERS)
                after = None
                if "after_block" in b:
                    after = questionnaire(f"{bp}.after_block", b["after_block"])
                each: list[str] = []
                given = b.get("after_each_trial", MISSING)
                raw_each: list[Any] = [] if given is MISSING else [given] if isinstance(given, str) else given
                if given is not MISSING and (not isinstance(given, str | list) or not raw_each):
                    why = "expected a questionnaire id or a non-empty array of them"
                    c.bad(f"{bp}.after_each_trial", given, why)
                    raw_each = []
                if len({str(x) for x in raw_each}) != len(raw_each):
                    c.bad(f"{bp}.after_each_trial", raw_each, "each questionnaire at most once")
                for i, qid in enumerate(raw_each):
                    key = f"{bp}.after_each_trial" + (f"[{i}]" if isinstance(given, list) else "")
                    got = questionnaire(key, qid, kinds=("likert", "form"))
                    if got is not None:
                        each.append(got)
                if after is not None and questionnaires[after].kind == "pairwise" and conds and comparisons:
                    usable = [cp for cp in comparisons if cp[0] in conds and cp[1] in conds]
                    if not usable:
                        c.bad(
                            f"{bp}.after_block",
                            after,
                            "no study.comparisons pair is inside this block's conditions",
                        )
                if None in (bid, sc, limit, conds, corder) or sc is None:
                    continue
                assert bid is not None and limit is not None and conds is not None and corder is not None
                blocks.append(
                    BlockSpec(
                        id=bid,
                        scene=sc[0],
                        scene_name=sc[1],
                        scene_hash=sc[2],
                        time_limit_s=limit,
                        conditions=conds,
                        condition_order=corder,
                        after_block=after,
                        after_each_trial=tuple(each),
                        responsibility=rho,
                    )
                )
            if order is not None and blocks:
                steps.append(StepSpec(id=sid, kind=kind, order=order, blocks=tuple(blocks), text=text or ""))

    if c.problems:
        raise ProtocolError(c.problems)
    assert name is not None and seed is not None and conditions is not None and labels is not None
    assert comparisons is not None and eye_height is not None
    return Protocol(
        name=name,
        title=title or name,
        seed=seed,
        conditions=conditions,
        labels=labels,
        comparisons=comparisons,
        eye_height_m=eye_height,
        steps=tuple(steps),
        questionnaires=questionnaires,
        source=source,
        content_hash=content_hash,
        base_dir=base_dir,
        participant_sex=p_sex or "",
        participant_carrying=p_carrying or "",
    )


def _comparisons(
    c: Checker, v: Any, conditions: tuple[str, ...] | None
) -> tuple[tuple[str, str], ...] | None:
    if v is MISSING:
        return ()
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        c.bad("study.comparisons", v, 'expected an array of "left/right" condition pairs')
        return None
    out: list[tuple[str, str]] = []
    for k, x in enumerate(v):
        parts = x.split("/")
        if (
            len(parts) != 2
            or parts[0] == parts[1]
            or (conditions is not None and not set(parts) <= set(conditions))
        ):
            c.bad(f"study.comparisons[{k}]", x, 'expected "left/right": two different study.conditions')
            continue
        pair = (parts[0], parts[1])
        if pair in out or pair[::-1] in out:
            c.bad(f"study.comparisons[{k}]", x, "duplicate comparison")
            continue
        out.append(pair)
    return tuple(out)


def _limit(c: Checker, d: dict[str, Any], path: str) -> float | None:
    return c.number(d, "time_limit_s", f"{path}.time_limit_s", check=lambda x: x > 0, expect="> 0 s")


def _rho(c: Checker, d: dict[str, Any], path: str) -> float | None:
    return c.number(
        d,
        "responsibility",
        f"{path}.responsibility",
        required=False,
        check=lambda x: 0 <= x <= 1,
        expect="in [0, 1]",
    )


def scene_path(scene: str, base_dir: Path) -> Path:
    """A protocol's scene reference as a file: ``.toml``/``.xml`` paths relative to ``base_dir``
    (the protocol's folder; absolute paths stay as they are), other names the shipped scenes."""
    from pedvr.scenes import resolve_scene

    if scene.endswith((".toml", ".xml")):
        return (base_dir / scene).resolve()
    return resolve_scene(scene).resolve()


_CUE_KEYS = ("exhibit", "at_s", "guide_state")


def _demo_cues(c: Checker, st: dict[str, Any], path: str, scene_file: Path | None,
               limit: float | None) -> tuple[DemoCue, ...]:
    """A trial step's ``demonstrate``: one table or an array of tables ``{ exhibit, at_s, guide_state }``
    (issue 15: a demonstration "triggered ... by the study protocol"). ``exhibit`` names an exhibit
    of the trial's scene, ``at_s`` a time in [0, time_limit_s) and ``guide_state``, optional, a BFSM
    state of the scene. Sorted by time (ties keep the protocol's order)."""
    v = st.get("demonstrate", MISSING)
    if v is MISSING:
        return ()
    key = f"{path}.demonstrate"
    raw = [v] if isinstance(v, dict) else v
    if not isinstance(raw, list) or not raw or not all(isinstance(x, dict) for x in raw):
        c.bad(key, v, 'expected a table { exhibit = "...", at_s = ... } or an array of them')
        return ()
    exhibits: tuple[str, ...] | None = None
    states: tuple[str, ...] | None = None
    if scene_file is not None:  # a scene that does not load was reported under .scene already
        from pedvr.scene.loader import load_any

        try:
            b = load_any(scene_file, seed=None).behavior
        except SceneError:
            b = None
        if b is not None:
            exhibits = tuple(o.name for o in b.objects if o.kind == "exhibit")
            states = tuple(b.states)
        else:
            exhibits, states = (), ()
    out: list[DemoCue] = []
    for k, d in enumerate(raw):
        where = key if isinstance(v, dict) else f"{key}[{k}]"
        c.known(d, where, _CUE_KEYS)
        ex = c.string(d, "exhibit", f"{where}.exhibit")
        if ex is not None and exhibits is not None and ex not in exhibits:
            c.bad(f"{where}.exhibit", ex, "no such exhibit in the trial's scene; its exhibits: "
                  + (", ".join(exhibits) or "none"))
            ex = None
        at = c.number(d, "at_s", f"{where}.at_s", check=lambda x: x >= 0.0, expect=">= 0 s")
        if at is not None and limit is not None and at >= limit:
            c.bad(f"{where}.at_s", d["at_s"], f"must be before the trial's time_limit_s ({limit:g} s)")
            at = None
        gs = c.string(d, "guide_state", f"{where}.guide_state", required=False)
        if gs is not None and states is not None and gs not in states:
            c.bad(f"{where}.guide_state", gs, "no such behavior state in the trial's scene; its states: "
                  + (", ".join(states) or "none"))
            gs = None
        if ex is not None and at is not None and (gs is not None or "guide_state" not in d):
            out.append(DemoCue(exhibit=ex, at_s=at, guide_state=gs))
    return tuple(sorted(out, key=lambda q: q.at_s))


def _resolve_scene(c: Checker, key: str, v: str, base_dir: Path) -> tuple[str, str, str] | None:
    """``(reference as written, scene name, content hash)``, or None after recording the problem."""
    from pedvr.scene.loader import load_any

    path = scene_path(v, base_dir)
    if not path.is_file():
        c.bad(key, v, "no such scene (neither a shipped scene name nor a file relative to the protocol)")
        return None
    try:
        cfg = load_any(path, seed=None)
    except SceneError as exc:
        for line in exc.problems:
            c.bad(key, v, f"scene problem: {line}")
        return None
    if not cfg.user.enabled or not cfg.user.route:
        c.bad(key, v, "a study scene needs a user with a red-sphere route ([user] route = [...])")
        return None
    return v, cfg.name, cfg.content_hash


# -- planning --------------------------------------------------------------------------------


def participant_number(participant: str) -> int:
    """The number in a participant id (``P07`` → 7); it selects the counterbalancing rows."""
    m = re.search(r"(\d+)$", participant)
    if m is None or int(m.group(1)) < 1:
        from pedvr.errors import UsageError

        raise UsageError(
            f"participant {participant!r}: expected an id ending in a number >= 1, like P07 "
            "(the number selects the counterbalanced orders)"
        )
    return int(m.group(1))


def _ordered(order: str, *, n: int, number: int, seed: int, offset: int = 0) -> list[int]:
    if order == "balanced_latin_square":
        return square_row(number=number, n=n, offset=offset)
    if order == "random":
        return random_order(n=n, seed=seed)
    return list(range(n))


def plan_for(protocol: Protocol, *, number: int) -> list[PlannedStep]:
    """Expand ``protocol`` for participant ``number`` into the session's steps.

    Counterbalancing (PedVR §6.4): blocks of a ``blocks`` step follow row
    ``number`` of a balanced square over the blocks; inside block ``j`` the
    conditions follow row ``number + j·R/B`` of the balanced square over the
    conditions (R rows, B blocks), so the blocks of one participant use
    different rows and every R consecutive participants cover every order of
    every block once. Conditions are labelled A, B, C by order of appearance
    within each block. Pairwise comparisons are shown left/right as decided by
    :func:`left_right_flipped`. Sweeps in ``random`` order are shuffled with a
    seed made from the study seed, participant number and step id. All three
    conditions of a block share one crowd seed, so they differ only in the model.
    """
    out: list[PlannedStep] = []

    def add(**kw: Any) -> None:
        out.append(PlannedStep(index=len(out), **kw))

    for st in protocol.steps:
        if st.kind == "instructions":
            add(key=st.id, kind="instructions", title=st.id, text=st.text)
            continue
        if st.kind == "questionnaire":
            assert st.questionnaire is not None
            add(
                key=st.id,
                kind="questionnaire",
                title=protocol.questionnaires[st.questionnaire].title,
                questionnaire=st.questionnaire,
                optional=st.optional,
            )
            continue
        if st.text:  # trial, sweep and blocks steps may open with their own instructions page
            add(key=f"{st.id}/instructions", kind="instructions", title=f"{st.id}: instructions",
                text=st.text)
        if st.kind in ("trial", "sweep"):
            assert st.scene is not None and st.scene_name is not None and st.time_limit_s is not None
            cond = st.condition or protocol.conditions[0]

            def spec(order: int | None, rho: float | None, st: StepSpec = st, cond: str = cond) -> TrialSpec:
                assert st.scene is not None and st.scene_name is not None and st.time_limit_s is not None
                assert st.scene_hash is not None
                return TrialSpec(scene=st.scene, scene_name=st.scene_name, scene_hash=st.scene_hash,
                                 condition=cond, label=None,
                                 order=order, responsibility=rho,
                                 seed=stable_seed(protocol.seed, number, st.id),
                                 time_limit_s=st.time_limit_s, record_trajectory=st.record_trajectories,
                                 demonstrations=st.demonstrations)

            if st.kind == "trial":
                add(key=st.id, kind="trial", title=f"{st.id} ({st.scene_name})", scenario=st.scene_name,
                    condition=cond, trial=spec(None, st.responsibility), design="single")
                continue
            order = _ordered(st.order, n=len(st.values), number=number,
                             seed=stable_seed(protocol.seed, number, st.id, "order"))
            for pos, vi in enumerate(order):
                rho = st.values[vi]
                add(
                    key=f"{st.id}/rho{rho:g}",
                    kind="trial",
                    title=f"{st.id} {pos + 1}/{len(order)} ({st.scene_name}, responsibility {rho:g})",
                    block=st.id,
                    scenario=st.scene_name,
                    condition=cond,
                    trial=spec(pos + 1, rho),
                    design="sweep",
                    assignment={"sweep_order": [st.values[i] for i in order]},
                )
        else:
            border = _ordered(
                st.order,
                n=len(st.blocks),
                number=number,
                seed=stable_seed(protocol.seed, number, st.id, "order"),
            )
            for bpos, bi in enumerate(border):
                b = st.blocks[bi]
                _plan_block(
                    protocol,
                    b,
                    add,
                    number=number,
                    block_position=bpos,
                    block_index=bi,
                    n_blocks=len(st.blocks),
                    step_id=st.id,
                    block_order=[st.blocks[i].id for i in border],
                )
    return out


def _plan_block(
    protocol: Protocol,
    b: BlockSpec,
    add: Any,
    *,
    number: int,
    block_position: int,
    block_index: int,
    n_blocks: int,
    step_id: str,
    block_order: list[str],
) -> None:
    n = len(b.conditions)
    rows = rows_in_square(n)
    corder = _ordered(
        b.condition_order,
        n=n,
        number=number,
        offset=block_index * rows // n_blocks,
        seed=stable_seed(protocol.seed, number, step_id, b.id, "order"),
    )
    conds = [b.conditions[i] for i in corder]
    label_of = {cond: protocol.labels[k] for k, cond in enumerate(conds)}
    seed = stable_seed(protocol.seed, number, step_id, b.id)
    assignment = {
        "block_order": block_order,
        "condition_order": conds,
        "labels": {label_of[cd]: cd for cd in conds},
    }
    key0 = f"{step_id}/{b.id}"
    for pos, cond in enumerate(conds):
        spec = TrialSpec(
            scene=b.scene,
            scene_name=b.scene_name,
            scene_hash=b.scene_hash,
            condition=cond,
            label=label_of[cond],
            order=pos + 1,
            responsibility=b.responsibility,
            seed=seed,
            time_limit_s=b.time_limit_s,
            record_trajectory=True,
        )
        add(
            key=f"{key0}/trial{pos + 1}",
            kind="trial",
            title=f"{b.id} trial {label_of[cond]} ({pos + 1}/{n}, scenario {block_position + 1}/{n_blocks})",
            block=b.id,
            scenario=b.scene_name,
            condition=cond,
            label=label_of[cond],
            trial=spec,
            design="block",
            assignment=assignment,
        )
        for qid in b.after_each_trial:
            add(
                key=f"{key0}/trial{pos + 1}/{qid}",
                kind="questionnaire",
                title=f"{protocol.questionnaires[qid].title} ({b.id}, {label_of[cond]})",
                questionnaire=qid,
                block=b.id,
                scenario=b.scene_name,
                condition=cond,
                label=label_of[cond],
            )
    if b.after_block is None:
        return
    q = protocol.questionnaires[b.after_block]
    pairs: list[ShownPair] = []
    if q.kind == "pairwise":
        usable = [cp for cp in protocol.comparisons if cp[0] in conds and cp[1] in conds]
        cycle = rows_in_square(n)
        for ci, (left, right) in enumerate(usable):
            flipped = left_right_flipped(number=number, block=block_index, comparison=ci, cycle=cycle)
            sl, sr = (right, left) if flipped else (left, right)
            pairs.append(
                ShownPair(
                    comparison=f"{left}/{right}",
                    left_condition=sl,
                    right_condition=sr,
                    left_label=label_of[sl],
                    right_label=label_of[sr],
                    flipped=flipped,
                )
            )
        # Shown in label order (A–B, A–C, B–C), whatever the fixed orientation.
        pairs.sort(key=lambda p: tuple(sorted((p.left_label, p.right_label))))
    add(
        key=f"{key0}/{b.after_block}",
        kind="questionnaire",
        title=f"{q.title} ({b.id})",
        questionnaire=b.after_block,
        block=b.id,
        scenario=b.scene_name,
        pairs=tuple(pairs),
        assignment=assignment,
    )
