"""Preconditions the operators' ``poll`` share: each returns what it checked for, or None / False with the poll
message set (one line, an animator's words)."""

import bpy

__all__ = ["armature_or_message", "two_actions_or_message"]


def armature_or_message(cls, context):
    """The active object when it is an armature, else None with the poll message set."""
    obj = context.active_object
    if obj is None or obj.type != "ARMATURE":
        cls.poll_message_set("The active object must be an armature")
        return None
    return obj


def two_actions_or_message(cls, what: str) -> bool:
    """True when the file holds two actions or more, else False with the message "``what`` needs two actions in
    the file"."""
    if len(bpy.data.actions) < 2:
        cls.poll_message_set(f"{what} needs two actions in the file")
        return False
    return True
