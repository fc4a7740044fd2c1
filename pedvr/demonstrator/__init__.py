"""Virtual demonstrators: PLACE (Huang & Kallmann, "Planning Motions and Placements for Virtual
Demonstrators", §3–8 and Appendix A), with the user as the observer who may walk around.

Modules
-------
``model``        the placement model: Appendix A's polynomials (:func:`placement_model`) and its
                 local frame at the target.
``stage``        the world and the body as the planner sees them (obstacle prisms with heights and
                 partial occlusion, the walkable mesh; eye height, shoulder, arm).
``placement``    candidate search every 5° around the target, validity, the ranking cost, the
                 sorted list (§4); resumable across behavior ticks.
``arm``          the pointing / touching action: feasibility, the hand's trajectory and the
                 collision potential around obstacle spheres (§6).
``coordination`` the 0.58 s locomotion–action window matched to the arm swing (§7).
``engagement``   the gaze model: floor, target, observer with Δt, declining durations (§8).
``demonstration`` the exhibit smart object and the ``demonstrate`` node and tree: a demonstration
                 as a behavior, with re-planning when the observer (the user) moves.

Importing the package registers the ``exhibit`` object kind, the ``demonstrate`` node type and
the ``demonstrate`` library tree (the scene loader does).
"""

from pedvr.demonstrator import demonstration as demonstration
from pedvr.demonstrator.model import PlacementError, placement_model

__all__ = ["PlacementError", "demonstration", "placement_model"]
