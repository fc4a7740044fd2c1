"""Doors and doorway etiquette (Huang & Terzopoulos). Today: door mechanics only (:mod:`.doors`)."""

from pedvr.etiquette.doors import DoorLeaves

__all__ = ["DoorLeaves"]
