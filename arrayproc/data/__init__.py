"""Package data: example chains, scenarios, tracker configurations and transmission-loss tables.

Read through :func:`data_path`, which works from a source checkout and from an installed wheel
alike (``importlib.resources``), never from paths relative to the repository.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def data_path(*parts: str) -> Path:
    """Filesystem path of a bundled data file, e.g. ``data_path("chains", "power.toml")``.

    Parameters
    ----------
    *parts : str
        Folder (``chains``, ``scenarios``, ``trackers``, ``tl``) and file name.

    Returns
    -------
    pathlib.Path
        The file inside the installed package (it may not exist: callers check).
    """
    return Path(str(files(__name__).joinpath(*parts)))
