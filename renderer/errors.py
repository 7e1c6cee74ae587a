"""Errors the renderer reports to the user (as opposed to programming errors)."""


class SceneError(Exception):
    """The input cannot be turned into a scene: missing or unreadable file, corrupt layer, ...

    The message names the file (and the prim path when one prim is at fault); command-line
    front ends print it without a traceback."""
