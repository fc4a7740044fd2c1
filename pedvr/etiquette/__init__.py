"""Doors and doorway etiquette (Huang & Terzopoulos, "Door and Doorway Etiquette for Virtual Humans").

Modules
-------
``doors``      door hardware: sprung hinged leaves (a pull side and a push side, or
               double-acting), App. A's control functions, the hand driving a leaf.
``decision``   the holding decision network of §5 (Tables 2 and 3).
"""

from pedvr.etiquette.decision import care_factor, effort_factor, holding_probabilities
from pedvr.etiquette.doors import DoorLeaves

__all__ = ["DoorLeaves", "care_factor", "effort_factor", "holding_probabilities"]
