"""Errors the renderer reports to the user (as opposed to programming errors)."""


class SceneError(Exception):
    """The input cannot be turned into a scene: missing or unreadable file, corrupt layer, ...

    The message names the file (and the prim path when one prim is at fault); command-line
    front ends print it without a traceback."""


class RenderError(Exception):
    """Invalid render options (bad sizes, unknown sampler...) or a checkpoint that does not fit;
    the message says which value and where it came from."""
