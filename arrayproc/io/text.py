"""Text values read back from HDF5: attributes and string datasets come as ``bytes`` or
``str`` depending on how h5py stored them; :func:`as_text` gives ``str`` either way."""

from __future__ import annotations

__all__ = ["as_text"]


def as_text(v: object) -> str:
    """An HDF5 attribute or string-dataset value as ``str``.

    Parameters
    ----------
    v : object
        ``bytes`` (decoded as UTF-8) or anything ``str()`` accepts.

    Returns
    -------
    str
    """
    return v.decode() if isinstance(v, bytes) else str(v)
