"""A participant's session: a resumable state machine over the planned steps.

States are the steps of :func:`pedvr.study.protocol.plan_for` (instructions,
questionnaire, trial), each ``pending``, ``done`` or ``skipped`` in the
``steps`` table. A session runs the pending steps in order; every answer and
every finished trial is committed as it happens (:mod:`pedvr.study.store`),
so after a crash or an abort ``--resume`` continues at the first unfinished
step — inside a questionnaire, at the first unanswered item.

Trials follow PedVR §6.2: the participant follows the red sphere; a trial
ends when the last sphere is reached or at the time limit. Each frame the
runner advances the simulation to the time the participant's backend asks
for and records one sample (head pose, every agent, contacts, distance to
the nearest agent, red spheres reached so far).

Every answer is stored with its response time: seconds on the console's
monotonic clock from the moment the runner hands the item to the
participant (:meth:`Participant.ask`) to the moment the answer is confirmed.
The in-app participant draws the item on its next frame, so the time
includes at most one frame (11 ms at 90 Hz) before the item is visible.

A session ended by Ctrl-C, SIGTERM or SIGHUP (:mod:`pedvr.signals`), or
by the participant closing the view, is ``aborted`` with an ``abort`` event
saying why; a trial running at that moment is marked ``interrupted`` at once,
its samples up to then kept (and flagged in the export), and ``--resume``
runs it again from its start.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial import cKDTree

from pedvr.errors import UsageError
from pedvr.study.console import Command, ExperimenterConsole
from pedvr.study.errors import AnswerError, ParticipantExistsError, StudyStoreError
from pedvr.study.presenter import ExperimenterCommand, Page, Participant, Question
from pedvr.study.protocol import (
    DemoCue,
    PlannedStep,
    Protocol,
    ShownPair,
    TrialSpec,
    participant_number,
    plan_for,
)
from pedvr.study.questionnaire import Response, check_response, recode
from pedvr.study.store import StepRow, StudyStore

if TYPE_CHECKING:
    from pedvr.sim import Simulation

SAMPLE_CHUNK_FRAMES = 90  # samples are committed about once per simulated second at 90 Hz
DECLINED = "consent declined"  # the reason stored with the consent step a participant declined


def software_version() -> str:
    """pedvr's version and, from a git checkout, its commit: ``0.2.0+g1a2b3c4d5e`` (``.dirty`` with
    uncommitted changes to the code), so a methods section can name the exact code that ran."""
    from pedvr.provenance import provenance

    p = provenance()
    version = str(p["pedvr_version"])
    commit = p.get("pedvr_git_commit")
    if commit:
        version += f"+g{str(commit)[:10]}" + (".dirty" if p.get("pedvr_git_dirty") else "")
    return version


@dataclass(frozen=True)
class SessionResult:
    """How a session ended: ``finished``, ``aborted``, ``withdrawn`` or ``already_finished``."""

    status: str
    participant: str
    session_id: int | None
    steps_done: int
    steps_total: int
    message: str


class Session:
    """Run (or resume) one participant through a protocol.

    ``max_trial_s`` caps every trial's time limit (dry runs and tests);
    ``resume`` must be given exactly when the participant already exists.
    """

    def __init__(
        self,
        *,
        protocol: Protocol,
        store: StudyStore,
        participant_id: str,
        participant: Participant,
        console: ExperimenterConsole,
        backend: str,
        resume: bool = False,
        max_trial_s: float | None = None,
        simulated: bool = False,
    ) -> None:
        if max_trial_s is not None and max_trial_s <= 0:
            raise UsageError(f"max_trial_s = {max_trial_s}: must be > 0")
        self.protocol = protocol
        self.store = store
        self.pid = participant_id
        self.number = participant_number(participant_id)
        self.participant = participant
        self.console = console
        self.backend = backend
        self.resume = resume
        self.max_trial_s = max_trial_s
        self.simulated = simulated
        self.plan = plan_for(protocol, number=self.number)
        self.session_id: int | None = None
        self._current: int | None = None

    # -- the state machine ------------------------------------------------------------------

    def run(self) -> SessionResult:
        rows = self._open()
        total = len(self.plan)
        if all(r.status != "pending" for r in rows):
            self.store.settle_last_session(self.pid, "finished")  # killed after its last step: it finished
            return SessionResult(
                "already_finished",
                self.pid,
                None,
                total,
                total,
                f"participant {self.pid} has finished the protocol; nothing to resume",
            )
        first = next(r.index for r in rows if r.status == "pending")
        self.session_id = self.store.start_session(
            participant=self.pid,
            software_version=software_version(),
            protocol_source=self.protocol.source,
            protocol_hash=self.protocol.content_hash,
            seed=self.protocol.seed,
            backend=self.backend,
            participant_kind=self.participant.kind,
            resumed=self.resume,
        )
        self._store_questionnaires()
        self.console.on_event = self._event
        self.console.session_started(
            participant=self.pid,
            protocol=self.protocol.title,
            resumed_at=first if self.resume else None,
            total=total,
        )
        if self.resume:
            self._event("resume_session", f"at step {first + 1}: {self.plan[first].key}")
        status = "finished"
        try:
            for row in rows:
                if row.status != "pending":
                    continue
                step = self.plan[row.index]
                self._current = step.index
                nxt = next(
                    (self.plan[r.index].title for r in rows[row.index + 1 :] if r.status == "pending"), None
                )
                self.console.step_started(index=step.index, total=total, title=step.title, next_title=nxt)
                outcome = self._run_step(step)
                if outcome.kind == "abort":
                    status = "aborted"
                    break
                if outcome.kind == "withdrawn":
                    status = "withdrawn"
                    self.store.mark_step(
                        participant=self.pid,
                        index=step.index,
                        status="done",
                        session_id=self.session_id,
                        reason=DECLINED,
                    )
                    break
                st = "skipped" if outcome.kind == "skip" else "done"
                self.store.mark_step(
                    participant=self.pid,
                    index=step.index,
                    status=st,
                    session_id=self.session_id,
                    reason=outcome.reason or None,
                )
                self.console.step_finished(
                    index=step.index, total=total, title=step.title, status=st, detail=outcome.reason
                )
        except KeyboardInterrupt as exc:
            self.store.rollback_open()
            self._event("abort", f"interrupted ({str(exc) or 'Ctrl-C'})")
            self.store.end_session(self.session_id, "aborted")
            raise
        self.store.end_session(self.session_id, status)
        if status in ("finished", "withdrawn"):
            self.store.set_participant_status(self.pid, status)
        done = sum(1 for r in self.store.steps(self.pid) if r.status != "pending")
        msg = {
            "finished": f"participant {self.pid} finished the protocol",
            "aborted": f"session aborted at step {(self._current or 0) + 1}/{total}; continue with --resume",
            "withdrawn": f"participant {self.pid} declined consent; the session ended",
        }[status]
        self.console.say(msg)
        return SessionResult(status, self.pid, self.session_id, done, total, msg)

    def _open(self) -> list[Any]:
        existing = self.store.participant(self.pid)
        specs = [(s.index, s.key, s.kind, s.to_json()) for s in self.plan]
        if existing is None:
            if self.resume:
                raise StudyStoreError(
                    f"participant {self.pid} has no session in {self.store.path} to resume; "
                    "start without --resume"
                )
            claim_database(self.store, self.protocol)
            self.store.register(
                participant=self.pid,
                number=self.number,
                simulated=self.simulated,
                protocol_hash=self.protocol.content_hash,
                plan=specs,
            )
            self.store.set_meta("comparisons", [f"{a}/{b}" for a, b in self.protocol.comparisons])
            return self.store.steps(self.pid)
        if not self.resume:
            raise ParticipantExistsError(
                f"participant {self.pid} already exists in {self.store.path} (status {existing['status']}); "
                "use --resume to continue their session, or choose another participant id"
            )
        if existing["status"] == "withdrawn":
            raise StudyStoreError(f"participant {self.pid} declined consent; there is nothing to resume")
        rows = self.store.steps(self.pid)
        differences = plan_differences(rows, self.plan, self.protocol)
        if existing["protocol_hash"] != self.protocol.content_hash:
            raise StudyStoreError(
                "\n".join(
                    [
                        f"participant {self.pid} started with protocol {existing['protocol_hash']}, but "
                        f"{self.protocol.source} is now {self.protocol.content_hash}; "
                        "resume with the original protocol file",
                        *(
                            differences
                            or [
                                f"participant {self.pid}: the plan is the same; only the file's text changed "
                                "(comments or layout)"
                            ]
                        ),
                    ]
                )
            )
        if differences:
            raise StudyStoreError(
                "\n".join(
                    [
                        f"participant {self.pid}: the stored plan (number {self.number}) differs from what "
                        f"{self.protocol.source} plans now; resume with the protocol and scenes as they "
                        "were:",
                        *differences,
                    ]
                )
            )
        self.store.close_dead_sessions(self.pid)
        self.store.mark_interrupted_trials(self.pid)
        if any(r.reason == DECLINED for r in rows):  # killed after the consent was declined
            self.store.settle_last_session(self.pid, "withdrawn")
            raise StudyStoreError(f"participant {self.pid} declined consent; there is nothing to resume")
        return rows

    def _store_questionnaires(self) -> None:
        """Keep each questionnaire's file text in the database (meta ``questionnaire_files``), so the
        analysis scores answers by the definitions they were given with, wherever the files are then.
        A file changed between sessions replaces the stored text (the latest session's wins)."""
        stored = self.store.meta("questionnaire_files") or {}
        now = {qid: q.document for qid, q in self.protocol.questionnaires.items() if q.document}
        if any(stored.get(k) != v for k, v in now.items()):
            self.store.set_meta("questionnaire_files", {**stored, **now})

    def _event(self, kind: str, detail: str | None) -> None:
        assert self.session_id is not None
        self.store.log_event(
            session_id=self.session_id,
            participant=self.pid,
            step_index=self._current,
            kind=kind,
            detail=detail,
        )

    def _run_step(self, step: PlannedStep) -> _Outcome:
        cmd = self.console.check()
        if cmd is not None:
            return self._command(cmd)
        try:
            if step.kind == "instructions":
                self.participant.show(Page(title=step.title, text=step.text))
                return _Outcome("done")
            if step.kind == "questionnaire":
                return self._questionnaire(step)
            return self._trial(step)
        except ExperimenterCommand as exc:  # skip / abort given while a panel waited (answers kept)
            return self._command(exc.command)

    def _command(self, cmd: Command) -> _Outcome:
        self._event(cmd.kind, cmd.reason or None)
        return _Outcome(cmd.kind, cmd.reason)

    # -- questionnaires ---------------------------------------------------------------------

    def _questionnaire(self, step: PlannedStep) -> _Outcome:
        assert step.questionnaire is not None and self.session_id is not None
        q = self.protocol.questionnaires[step.questionnaire]
        occurrence = sum(1 for s in self.plan[: step.index + 1] if s.questionnaire == q.id)
        pairs: list[ShownPair | None] = list(step.pairs) if q.kind == "pairwise" else [None]
        if q.kind == "pairwise" and not step.pairs:
            return _Outcome("done")
        done = self.store.answered(self.pid, step.index)
        todo = [(item, pair) for item in q.items for pair in pairs]
        if q.instructions and not done:
            self.participant.show(Page(title=q.title, text=q.instructions))
        for k, (item, pair) in enumerate(todo):
            comparison = pair.comparison if pair else None
            if (item.id, comparison) in done:
                continue
            if k:
                cmd = self.console.check()
                if cmd is not None:
                    return self._command(cmd)
            required = item.required and not step.optional
            question = Question(
                questionnaire=q,
                item=item,
                position=k + 1,
                count=len(todo),
                pair=pair,
                scenario=step.scenario,
                condition=step.condition,
                label=step.label,
                occurrence=occurrence,
                required=required,
            )
            shown = self.console.clock()
            raw = self.participant.ask(question)
            response_time = self.console.clock() - shown
            resp = self._validate(q, item, raw, required=required)
            self._store_answer(step, q, item, pair, resp, response_time_s=response_time)
            if item.kind == "consent" and resp.text == "no":
                return _Outcome("withdrawn")
        return _Outcome("done")

    def _validate(self, q: Any, item: Any, raw: Response, *, required: bool) -> Response:
        if not required and raw.value is None and (raw.text is None or raw.text == ""):
            return Response()
        try:
            return check_response(q, replace(item, required=required), raw)
        except AnswerError as exc:
            raise AnswerError([f"participant {self.pid}: {p}" for p in exc.problems]) from None

    def _store_answer(
        self,
        step: PlannedStep,
        q: Any,
        item: Any,
        pair: ShownPair | None,
        r: Response,
        *,
        response_time_s: float,
    ) -> None:
        assert self.session_id is not None
        raw_label = (
            q.label(item, int(r.value)) or None
            if (item.kind == "scale" and q.scale is not None and r.value is not None)
            else None
        )
        self.store.record_answer(
            participant=self.pid,
            session_id=self.session_id,
            step_index=step.index,
            step_key=step.key,
            questionnaire=q.id,
            questionnaire_kind=q.kind,
            item=item.id,
            item_number=item.number,
            block=step.block,
            scenario=step.scenario,
            condition=step.condition,
            label=step.label,
            comparison=pair.comparison if pair else None,
            left_condition=pair.left_condition if pair else None,
            right_condition=pair.right_condition if pair else None,
            left_label=pair.left_label if pair else None,
            right_label=pair.right_label if pair else None,
            flipped=None if pair is None else int(pair.flipped),
            raw_value=r.value,
            raw_label=raw_label,
            recoded_value=recode(q, item, r.value, flipped=bool(pair and pair.flipped))
            if item.kind in ("scale", "number")
            else None,
            text=r.text,
            response_time_s=response_time_s,
        )

    # -- trials -----------------------------------------------------------------------------

    def _trial(self, step: PlannedStep) -> _Outcome:
        from pedvr.scene.loader import load_any
        from pedvr.sim import Simulation

        spec = step.trial
        assert spec is not None and self.session_id is not None
        scene_file = self.protocol.scene_path(spec.scene)
        scene = load_any(scene_file, seed=spec.seed)
        if self.protocol.participant_sex or self.protocol.participant_carrying:  # door etiquette's Care
            u = scene.user
            scene = replace(scene, user=replace(u, sex=self.protocol.participant_sex or u.sex,
                                                carrying=self.protocol.participant_carrying or u.carrying))
        user_input = self.participant.trial_input(trial=spec, scene=scene)
        sim = Simulation(
            scene,
            seed=spec.seed,
            condition=spec.condition,
            responsibility=spec.responsibility,
            user_input=user_input,
            user_walk=self.participant.user_walk,
        )
        if sim.user is None:
            raise StudyStoreError(f"{scene_file}: the scene has no user; a study trial needs one")
        limit = spec.time_limit_s if self.max_trial_s is None else min(spec.time_limit_s, self.max_trial_s)
        trial_id = self.store.begin_trial(
            participant=self.pid,
            session_id=self.session_id,
            step_index=step.index,
            step_key=step.key,
            design=step.design,
            block=step.block,
            scenario=spec.scene_name,
            scene_source=str(scene_file),
            scene_hash=scene.content_hash,
            condition=spec.condition,
            label=spec.label,
            trial_order=spec.order,
            responsibility=sim.responsibility,
            seed=spec.seed,
            time_limit_s=limit,
        )
        rec = _SampleRecorder(
            self.store, trial_id=trial_id, clock=self.console.clock, keep_agents=spec.record_trajectory
        )
        rec.add(sim, frame=0, head=self.participant.head_pose(sim))
        total = int(sim.user.route.shape[0])
        cues = list(spec.demonstrations)  # the protocol's demonstrations to the participant, by time
        outcome = _Outcome("done")
        result = "time_limit"
        frame = 0
        try:
            with self.console.keys.live():
                while True:
                    if sim.user.route_done:
                        result = "reached_last_sphere"
                        break
                    if sim.t >= limit - 1e-9:
                        result = "time_limit"
                        break
                    cmd = self.console.check()
                    if cmd is not None:
                        outcome = self._command(cmd)
                        result = "skipped" if cmd.kind == "skip" else "aborted"
                        break
                    while cues and sim.t >= cues[0].at_s - 1e-9:
                        self._demonstrate(sim, cues.pop(0))
                    target = self.participant.present(sim)
                    if cues:  # stop at the next cue's frame, so it starts on time whatever the frame rate
                        target = min(target, max(cues[0].at_s, sim.t + sim.dt))
                    sim.advance_to(min(max(target, sim.t + sim.dt), limit))
                    frame += 1
                    rec.add(sim, frame=frame, head=self.participant.head_pose(sim))
                    self.console.trial_status(
                        sim_t=sim.t, limit_s=limit, spheres=sim.user.sphere, spheres_total=total
                    )
        except KeyboardInterrupt:
            # Ctrl-C, SIGTERM/SIGHUP or a closed view: keep what was recorded, say the trial was cut off
            self.store.rollback_open()
            rec.flush()
            self.store.finish_trial(
                trial_id,
                outcome="interrupted",
                sim_time_s=round(sim.t, 6),
                frames=frame + 1,
                spheres_reached=sim.user.sphere,
                spheres_total=total,
                min_user_distance_m=rec.min_distance,
                contacts=rec.contact_count,
            )
            raise
        rec.flush()
        self.store.finish_trial(
            trial_id,
            outcome=result,
            sim_time_s=round(sim.t, 6),
            frames=frame + 1,
            spheres_reached=sim.user.sphere,
            spheres_total=total,
            min_user_distance_m=rec.min_distance,
            contacts=rec.contact_count,
        )
        if outcome.kind == "done":
            outcome = _Outcome("done", f"{result}, {sim.user.sphere}/{total} spheres, {sim.t:.1f} s")
        return outcome


    def _demonstrate(self, sim: Simulation, cue: DemoCue) -> None:
        """Start a protocol cue's demonstration to the participant through the behavior layer (the
        scheduler, as a scene trigger does); the console says when no guide is free for it."""
        from pedvr.demonstrator.demonstration import demonstrate_to_user

        run = demonstrate_to_user(sim.scheduler, cue.exhibit, guide_state=cue.guide_state)
        if run is None:
            self.console.say(f"  demonstration of {cue.exhibit} at {cue.at_s:g} s: no free guide"
                             + (f" in state {cue.guide_state}" if cue.guide_state else "") + "; not started")


@dataclass(frozen=True)
class _Outcome:
    kind: str  # done | skip | abort | withdrawn
    reason: str = ""


class _SampleRecorder:
    """Per-frame rows for one trial, committed every :data:`SAMPLE_CHUNK_FRAMES` frames."""

    def __init__(
        self, store: StudyStore, *, trial_id: int, clock: Callable[[], float], keep_agents: bool
    ) -> None:
        self.store = store
        self.trial_id = trial_id
        self.clock = clock
        self.keep_agents = keep_agents
        self.samples: list[tuple[Any, ...]] = []
        self.agents: list[tuple[Any, ...]] = []
        self.contacts: list[tuple[Any, ...]] = []
        self.gaze: list[tuple[Any, ...]] = []
        self.doors: list[tuple[Any, ...]] = []
        self._doors_seen = 0
        self.min_distance: float | None = None
        self.contact_count = 0
        self.gaze_count = 0
        self._gaze_seen = 0
        self.demonstrations: list[tuple[Any, ...]] = []
        self._demo_seen = 0

    def add(self, sim: Any, *, frame: int, head: Any) -> None:
        crowd = sim.crowd
        # Gaze start/end events since the last frame (Simulation.metrics.gaze_events: the PedVR gaze
        # rule's, from BodyModel.gaze_rule, and demonstrators' eye contact, source "demonstration":
        # agent id, simulation time, "start"/"end", target), at this frame.
        events = sim.metrics.gaze_events
        for ev in events[self._gaze_seen :]:
            self.gaze.append(
                (
                    self.trial_id,
                    frame,
                    float(ev["t"]),
                    int(ev["agent"]),
                    str(ev["event"]),
                    str(ev.get("target", "user")),
                    str(ev.get("source", "rule")),
                )
            )
        self._gaze_seen = len(events)
        self.gaze_count = self._gaze_seen
        # Demonstrations to the participant (pedvr.demonstrator): start, each stroke point, end.
        demos = sim.scheduler.ctx.events
        for ev in demos[self._demo_seen :]:
            if ev.get("kind") == "demonstration" and ev.get("observer") == "user":
                self.demonstrations.append(
                    (self.trial_id, frame, float(ev["t"]), int(ev["id"]), int(ev["agent"]), str(ev["object"]),
                     str(ev["event"]), float(ev["x"]), float(ev["y"]), ev.get("outcome"))
                )
        self._demo_seen = len(demos)
        # Door etiquette's events since the last frame (who held a door for whom, HOF/HOL/NH, waits,
        # thank-yous; pedvr.etiquette.system.DoorEtiquette.events), at this frame.
        etiquette = getattr(sim, "etiquette", None)
        if etiquette is not None:
            self.doors.extend(door_row(self.trial_id, frame, ev, etiquette.user_id)
                              for ev in etiquette.events[self._doors_seen :])
            self._doors_seen = len(etiquette.events)
        pos, rad, ids, is_user = crowd.pos, crowd.radius, crowd.ids, crowd.is_user
        nearest = None
        user = np.flatnonzero(is_user)
        others = np.flatnonzero(~is_user)
        if user.size and others.size:
            nearest = float(np.linalg.norm(pos[others] - pos[user[0]], axis=1).min())
            self.min_distance = nearest if self.min_distance is None else min(self.min_distance, nearest)
        t = float(sim.t)
        (hx, hy, hz), (qw, qx, qy, qz) = head.position, head.orientation
        spheres = int(sim.user.sphere) if sim.user is not None else None
        self.samples.append(
            (self.trial_id, frame, self.clock(), t, hx, hy, hz, qw, qx, qy, qz, nearest, spheres)
        )
        if self.keep_agents:
            self.agents.extend(
                (self.trial_id, frame, int(i), int(u), float(p[0]), float(p[1]), float(h))
                for i, u, p, h in zip(ids, is_user, pos, crowd.heading, strict=True)
            )
        if len(crowd) > 1:
            pairs = cKDTree(pos).query_pairs(r=2.0 * float(rad.max()), output_type="ndarray")
            if pairs.size:
                i, j = pairs[:, 0], pairs[:, 1]
                ov = rad[i] + rad[j] - np.linalg.norm(pos[i] - pos[j], axis=1)
                for k in np.flatnonzero(ov > 0.0):
                    a, b = int(ids[i[k]]), int(ids[j[k]])
                    self.contacts.append(
                        (
                            self.trial_id,
                            frame,
                            t,
                            min(a, b),
                            max(a, b),
                            int(is_user[i[k]] or is_user[j[k]]),
                            float(ov[k]),
                        )
                    )
                    self.contact_count += 1
        if len(self.samples) >= SAMPLE_CHUNK_FRAMES:
            self.flush()

    def flush(self) -> None:
        """Commit the buffered rows. The buffers are emptied first, so a flush cut short by a signal
        loses at most this chunk and a second flush never writes a row twice."""
        samples, agents, contacts, gaze = self.samples, self.agents, self.contacts, self.gaze
        demos, doors = self.demonstrations, self.doors
        self.samples, self.agents, self.contacts, self.gaze = [], [], [], []
        self.demonstrations, self.doors = [], []
        if samples or agents or contacts or gaze or demos or doors:
            self.store.write_samples(samples=samples, agents=agents, contacts=contacts, gaze=gaze,
                                     demonstrations=demos, doors=doors)


def door_row(trial_id: int, frame: int, ev: dict[str, Any], user: int | None) -> tuple[Any, ...]:
    """One door event as a ``door_events`` row: the door, what happened, the agent it happened to,
    the other pedestrian (its follower or holder), the holding action, whether the user is one of
    the two, and the rest as JSON."""
    other = ev.get("follower", ev.get("holder"))
    with_user = bool(ev.get("for_user") or ev.get("to_user") or ev.get("user")) or (
        user is not None and user in (ev.get("agent"), other))
    named = ("t", "event", "door", "agent", "follower", "holder", "action")
    rest = {k: v for k, v in ev.items() if k not in named}
    return (trial_id, frame, float(ev["t"]), str(ev["door"]), str(ev["event"]), int(ev["agent"]),
            None if other is None else int(other), ev.get("action"), int(with_user),
            json.dumps(rest, sort_keys=True) if rest else None)


def claim_database(store: StudyStore, protocol: Protocol) -> None:
    """One database holds one study: refuse a participant of another protocol, else record the protocol.

    The database belongs to the protocol (its ``study.name``) that registered its first participant
    (meta ``protocol``: name and file). A participant of a protocol with another name is refused,
    naming both, before anything is written; an edited file of the same protocol is allowed (each
    participant keeps the hash of the file they ran with, and ``--resume`` insists on it).

    A database from before this record has none: it belongs to the protocol its participants ran
    with, recognised by a participant with the same protocol hash, or a session whose protocol file
    has the same name; anything else is refused, naming the files its sessions ran.
    """
    owner = store.meta("protocol")
    if owner is None:
        hashes = {r["protocol_hash"] for r in store.query("SELECT DISTINCT protocol_hash FROM participants")}
        sources = [r["protocol_source"] for r in store.query(
            "SELECT DISTINCT protocol_source FROM sessions ORDER BY session_id")]
        if hashes and protocol.content_hash not in hashes and not any(
            Path(src).name == Path(protocol.source).name for src in sources
        ):
            ran = ", ".join(sources) or f"protocol hash {', '.join(sorted(hashes))}"
            raise StudyStoreError(
                f"{store.path}: this study database holds the participants of {ran}, not of "
                f"{protocol.source}: give protocol {protocol.name!r} a database of its own (--db; default "
                f"./{protocol.name}.sqlite)"
            )
        store.set_meta("protocol", {"name": protocol.name, "source": protocol.source})
        return
    if owner.get("name") != protocol.name:
        raise StudyStoreError(
            f"{store.path}: this study database belongs to protocol {owner.get('name')!r} "
            f"({owner.get('source')}), not to {protocol.name!r} ({protocol.source}): give protocol "
            f"{protocol.name!r} a database of its own (--db; default ./{protocol.name}.sqlite)"
        )


MAX_DIFFERENCES = 12  # lines of a plan mismatch message before "... and N more"


def plan_differences(stored: list[StepRow], plan: list[PlannedStep], protocol: Protocol) -> list[str]:
    """What differs between a participant's stored plan and the protocol's plan now, one line each.

    Each line names the step (number and key) and the field with both values,
    e.g. ``step 5 (training): trial.time_limit_s was 120.0, the protocol now
    gives 60.0``; an edited scene file reads ``scene scenes/training.toml
    changed (content hash a1b2 -> c3d4)``. A scene reference that an older
    database stored as an absolute path counts as the same when it names the
    same file as the protocol's reference does now, and a missing stored
    hash (older databases) is not a difference.
    """
    out: list[str] = []
    if len(stored) != len(plan):
        out.append(f"the stored plan has {len(stored)} steps; the protocol now plans {len(plan)}")
    for row, step in zip(stored, plan, strict=False):
        where = f"step {row.index + 1} ({row.key})"
        if (row.key, row.kind) != (step.key, step.kind):
            out.append(f"{where}: the protocol now plans {step.key} ({step.kind}) here")
            continue
        old, new = json.loads(row.spec), json.loads(step.to_json())
        for path, a, b in _json_differences(old, new):
            if path == "trial.scene" and isinstance(a, str) and Path(a).is_absolute():
                if Path(a).resolve() == protocol.scene_path(str(b)):
                    continue
            if path == "trial.demonstrations" and a is None and b == []:
                continue  # a database from before trial cues (issue 15) planned none
            if path == "trial.scene_hash":
                if a is None:
                    continue
                ref = new["trial"]["scene"]
                out.append(
                    f"{where}: scene {ref} changed since the participant started (content hash {a} -> {b})"
                )
                continue
            out.append(f"{where}: {path} was {json.dumps(a)}, the protocol now gives {json.dumps(b)}")
    if len(out) > MAX_DIFFERENCES:
        out = [*out[: MAX_DIFFERENCES - 1], f"... and {len(out) - MAX_DIFFERENCES + 1} more differences"]
    return out


def _json_differences(a: Any, b: Any, path: str = "") -> list[tuple[str, Any, Any]]:
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[tuple[str, Any, Any]] = []
        for k in list(a) + [k for k in b if k not in a]:
            out += _json_differences(a.get(k), b.get(k), f"{path}.{k}" if path else k)
        return out
    return [] if a == b else [(path, a, b)]


def plan_json(step: PlannedStep) -> dict[str, Any]:
    """A planned step as the JSON stored in the ``steps`` table."""
    return json.loads(step.to_json())


__all__ = ["Session", "SessionResult", "TrialSpec", "plan_json", "software_version"]
