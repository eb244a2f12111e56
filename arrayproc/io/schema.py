"""Every product kind and its columns, in one place (docs/formats.md lists them).

A products group has an attribute ``kind``; its *columns* are datasets with one row per
snapshot, event, contact, track point or solution, appended as blocks come; its *axes* are
static datasets written once (e.g. the beams' cone angles). The products writer refuses a
kind or a column that is not declared here, the readers check that the required columns are
present, and ``arrayproc info``, the plots and the trackers find groups and columns through
this module.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.text import as_text


@dataclass(frozen=True)
class Column:
    """One column (or axis) of a product kind.

    Attributes
    ----------
    unit : str
        SI unit, ``dB re 1 µPa``, ``deg`` or ``""`` for counts, flags and names.
    doc : str
        What one value means.
    required : bool
        Whether every group of the kind has it.
    dtype : str
        numpy dtype of the values (what the writers store; an empty group gets it too).
    trailing : tuple
        Sizes of the dimensions after the rows (``(None,)`` for ``tau`` (n, n_ch), ``(4, 4)``
        for a state covariance); None where the size depends on the data (0 in an empty
        table).
    labels : tuple
        For each trailing dimension, the axes (static datasets of the kind) that may label
        it, the first present one used (``(("cone_deg", "bearing_deg"), ("freq",))`` for a
        LOFAR-gram); empty when no axis labels it.
    dims : tuple
        Names of the trailing dimensions in labelled arrays (:mod:`arrayproc.io.labelled`)
        where no axis labels them (``("channel",)``, ``("state_i", "state_j")``).
    """

    unit: str
    doc: str
    required: bool = True
    dtype: str = "f8"
    trailing: tuple = ()
    labels: tuple = ()
    dims: tuple = ()

    @property
    def long_name(self) -> str:
        """The doc without its shape note (``"band power per channel"``): the ``long_name``
        of labelled arrays and NetCDF/Zarr exports."""
        return re.sub(r",\s*\([^()]*\)$", "", self.doc).strip()


@dataclass(frozen=True)
class Kind:
    """A product kind: what one row is, its columns and its static axes."""

    name: str
    row: str
    columns: Mapping[str, Column]
    axes: Mapping[str, Column] = field(default_factory=dict)

    def names(self) -> set[str]:
        """Every dataset name the kind may hold."""
        return set(self.columns) | set(self.axes)

    def required(self) -> list[str]:
        """Columns every group of this kind must have."""
        return [k for k, c in self.columns.items() if c.required]


def _c(unit: str, doc: str, required: bool = True, dtype: str = "f8",
       trailing: tuple = (), labels: tuple = (), dims: tuple = ()) -> Column:
    return Column(unit, doc, required, dtype, trailing, labels, dims)


_ANY, _ANY2 = (None,), (None, None)  # trailing sizes set by the data (channels, beams, bins)
_CH, _XYZ, _STATE = ("channel",), ("axis_i", "axis_j"), ("state_i", "state_j")  # dim names
_PK = ("pair", "peak")
_BEAMS = ("cone_deg", "bearing_deg")  # the axes that label a beam dimension

_BEAM_AXES = {
    "cone_deg": _c("deg", "cone angle of each beam (line arrays)", False),
    "bearing_deg": _c("deg", "bearing of each beam (3-D steering)", False),
    "elevation_deg": _c("deg", "elevation of each beam (3-D steering)", False),
}

_KINDS = [
    Kind("power", "time block", {
        "time": _c("s", "centre time of the block"),
        "power_db": _c("dB re 1 µPa", "band power per channel, (n, n_ch)", trailing=_ANY,
                       dims=_CH),
    }),
    Kind("btr", "integrated snapshot", {
        "time": _c("s", "centre time of the integrated snapshots"),
        "power_db": _c("dB", "broadband beam power over the band, (n, n_beams)", trailing=_ANY,
                       labels=(_BEAMS,), dims=("beam",)),
    }, _BEAM_AXES),
    Kind("lofar", "integrated snapshot", {
        "time": _c("s", "centre time of the integrated snapshots"),
        "power_db": _c("dB", "TPSW-normalised spectrum per beam, (n, n_beams, n_freq)",
                        trailing=_ANY2, labels=(_BEAMS, ("freq",)), dims=("beam", "freq")),
    }, {**_BEAM_AXES, "freq": _c("Hz", "frequency of each bin")}),
    Kind("bearings", "peak on a BTR row or a LOFAR line, or a 2-D peak of azimuth × "
         "elevation beams", {
        "time": _c("s", "centre time of the snapshot"),
        "cone_deg": _c("deg", "cone angle of the peak (0 forward end-fire); line arrays, and "
                       "the angle off body x for volumetric/planar arrays"),
        "bearing_port_deg": _c("deg", "true bearing if the source is to port (line arrays); "
                               "the azimuth for volumetric/planar arrays"),
        "bearing_stbd_deg": _c("deg", "true bearing if the source is to starboard (line "
                               "arrays); the azimuth for volumetric/planar arrays"),
        "level_db": _c("dB re 1 µPa", "received level"),
        "snr_db": _c("dB", "peak over the TPSW background"),
        "freq_lo": _c("Hz", "lower edge of the band or line"),
        "freq_hi": _c("Hz", "upper edge of the band or line"),
        "spl_db": _c("dB re 1 µPa", "sound pressure level at the array (broadband)"),
        "rel_bearing_deg": _c("deg", "relative bearing of the peak, port negative "
                              "(relative-bearing beams)", False),
        "side": _c("", "+1 starboard, −1 port: resolved by the beams; 0 ambiguous "
                   "(relative-bearing beams)", False),
        "azimuth_deg": _c("deg", "true azimuth of the peak, clockwise from north (relative "
                          "to body x without a heading); volumetric/planar arrays "
                          "(azimuth × elevation beams)", False),
        "elevation_deg": _c("deg", "elevation of the peak, positive up; volumetric/planar "
                            "arrays", False),
        "sigma_deg": _c("deg", "σ of the azimuth from the peak's curvature and SNR; "
                        "volumetric/planar arrays", False),
    }),
    Kind("lines", "narrowband line (tonal) contact: one per snapshot and line", {
        "time": _c("s", "centre time of the snapshot"),
        "cone_deg": _c("deg", "cone angle of the line, interpolated across beams "
                       "(0 forward end-fire)"),
        "bearing_port_deg": _c("deg", "true bearing if the source is to port"),
        "bearing_stbd_deg": _c("deg", "true bearing if the source is to starboard"),
        "freq_hz": _c("Hz", "frequency of the line, interpolated across bins"),
        "bandwidth_hz": _c("Hz", "half-power width of the line"),
        "level_db": _c("dB re 1 µPa", "received level of the tone at a hydrophone"),
        "snr_db": _c("dB", "peak over the TPSW background"),
        "beam": _c("", "index of the beam holding the peak", dtype="i8"),
    }),
    Kind("doa", "root-MUSIC direction of one bin of a covariance group", {
        "time": _c("s", "mean centre time of the group's snapshots"),
        "freq": _c("Hz", "frequency of the bin"),
        "cone_deg": _c("deg", "cone angle of the root (0 forward end-fire)"),
        "radius": _c("", "modulus of the polynomial root (1 on the unit circle)"),
    }),
    Kind("ibf_removed", "plane wave removed by inverse beamforming", {
        "time": _c("s", "centre time of the snapshot"),
        "cone_deg": _c("deg", "cone angle of the removed wave"),
        "level_db": _c("dB re 1 µPa", "level of the removed wave"),
        "snr_db": _c("dB", "SNR of the removed wave"),
        "freq_lo": _c("Hz", "lower edge of the band"),
        "freq_hi": _c("Hz", "upper edge of the band"),
    }),
    Kind("detections", "transient event on a reference channel", {
        "time_start": _c("s", "start of the detection box"),
        "time_end": _c("s", "end of the detection box"),
        "freq_lo": _c("Hz", "lower edge of the detection box"),
        "freq_hi": _c("Hz", "upper edge of the detection box"),
        "snr_db": _c("dB", "peak band energy over the robust background"),
        "channel": _c("", "reference channel", dtype="i8"),
    }),
    Kind("delays", "snapshot or event", {
        "time": _c("s", "centre time"),
        "tau": _c("s", "delay of every channel relative to the reference, (n, n_ch)",
                  trailing=_ANY, dims=_CH),
        "sigma": _c("s", "1-sigma of each delay, (n, n_ch)", trailing=_ANY, dims=_CH),
        "corr": _c("", "peak normalised correlation, (n, n_ch)", trailing=_ANY, dims=_CH),
        "source": _c("", "source hypothesis of the row within its snapshot, strongest first "
                     "(tde peaks > 1: one row per source)", False, dtype="i8"),
        "closure": _c("", "fraction of the channel triplets through the reference whose "
                      "delays close (tde peaks > 1)", False),
    }),
    Kind("delay_peaks", "the K strongest correlation peaks of every channel pair (tde "
         "peaks > 1)", {
        "time": _c("s", "centre time"),
        "tau": _c("s", "lag of b after a per pair (a, b) and peak, (n, n_pairs, K); NaN "
                  "where absent", trailing=_ANY2, dims=_PK),
        "sigma": _c("s", "1-sigma of each lag, (n, n_pairs, K)", trailing=_ANY2, dims=_PK),
        "corr": _c("", "normalised peak correlation, (n, n_pairs, K)", trailing=_ANY2, dims=_PK),
        "snr_db": _c("dB", "SNR read from the correlation as a coherence, (n, n_pairs, K)",
                     trailing=_ANY2, dims=_PK),
    }, {"pairs": _c("", "channel pairs (a, b) of the pair axis, (n_pairs, 2)", dtype="i8",
                    trailing=(2,), dims=("pair_end",))}),
    Kind("positions", "localised event", {
        "time": _c("s", "event time"),
        "x": _c("m", "east"), "y": _c("m", "north"), "z": _c("m", "down"),
        "cov": _c("m²", "position covariance, (n, 3, 3)", trailing=(3, 3), dims=_XYZ),
        "tdoa_rms_s": _c("s", "RMS of the TDOA residuals"),
        "n_used": _c("", "channel pairs used", dtype="i8"),
        "source": _c("", "source hypothesis of the event's delays row (tde peaks > 1)",
                     False, dtype="i8"),
    }),
    Kind("directions", "event localised in direction only (planar or line arrays)", {
        "time": _c("s", "event time"),
        "bearing_deg": _c("deg", "true bearing of the arrival"),
        "elevation_deg": _c("deg", "elevation of the arrival", False),
        "sigma_deg": _c("deg", "1-sigma of the bearing", False),
        "tdoa_rms_s": _c("s", "RMS of the TDOA residuals", False),
        "n_used": _c("", "channel pairs used", False),
    }),
    Kind("range_doppler", "ping and beam near contacts", {
        "time": _c("s", "ping time", False),
        "ping": _c("", "ping index", dtype="i8"),
        "cone_deg": _c("deg", "beam cone angle"),
        "level_db": _c("dB", "matched-filter output, (n, n_range_rate, n_range)", trailing=_ANY2,
                       labels=(("range_rate_mps",), ("range_m",))),
    }, {"range_m": _c("m", "range axis"), "range_rate_mps": _c("m/s", "range-rate axis")}),
    Kind("contacts", "CFAR contact of one ping", {
        "time": _c("s", "echo time"),
        "ping": _c("", "ping index", dtype="i8"),
        "range_m": _c("m", "range (bistatic path / 2)"),
        "cone_deg": _c("deg", "cone angle"),
        "bearing_port_deg": _c("deg", "true bearing if to port"),
        "bearing_stbd_deg": _c("deg", "true bearing if to starboard"),
        "range_rate_mps": _c("m/s", "range rate, positive opening"),
        "absolute_doppler_mps": _c("m/s", "range rate with ownship motion removed (eq. 4.9)"),
        "absolute_doppler_port_mps": _c("m/s", "absolute Doppler if to port (differs in turns)",
                                        False),
        "absolute_doppler_stbd_mps": _c("m/s", "absolute Doppler if to starboard", False),
        "snr_db": _c("dB", "peak over the CFAR threshold's noise estimate"),
        "moving": _c("", "|absolute Doppler| above the threshold (on both sides)",
                     dtype="bool"),
        "waveform": _c("", "transmitted waveform name", dtype="S16"),
        "cells": _c("", "range-Doppler cells computed for the ping", False),
    }),
    Kind("nb_tracks", "narrowband EKF output sample", {
        "time": _c("s", "sample time"),
        "cone_deg": _c("deg", "cone angle estimate"),
        "freq_hz": _c("Hz", "frequency estimate"),
        "sigma_cone_deg": _c("deg", "1-sigma of the cone angle"),
        "sigma_freq_hz": _c("Hz", "1-sigma of the frequency"),
        "filter": _c("", "which of the two staggered filters", dtype="i1"),
    }),
    Kind("tracks", "track point", {
        "time": _c("s", "time of the estimate"),
        "track_id": _c("", "track number", dtype="i8"),
        "x": _c("m", "east"), "y": _c("m", "north"),
        "vx": _c("m/s", "east velocity"), "vy": _c("m/s", "north velocity"),
        "cov": _c("m², m²/s²", "state covariance, (n, 4, 4)", trailing=(4, 4), dims=_STATE),
        "status": _c("", "0 tentative, 1 confirmed, 2 deleted", False),
        "side_weight": _c("", "weight of the starboard hypothesis (L-R)", False),
        "own_x": _c("m", "ownship east"), "own_y": _c("m", "ownship north"),
        # multi-target mode (track/multi/)
        "cone_deg": _c("deg", "cone angle of a bearing track's cone filter", False),
        "sigma_cone_deg": _c("deg", "1-sigma of cone_deg", False),
        "row": _c("", "measurement row used (index in its products group; -1 coasted)",
                  False),
        "z": _c("m", "depth (positions tracks)", False),
        "vz": _c("m/s", "depth rate (positions tracks)", False),
        # lines+bearings tracks (track/multi/lines.py): the measurement of each point
        "row_kind": _c("", "group of row: 0 bearings, 1 lines, -1 coasted", False, "i1"),
        "meas_cone_deg": _c("deg", "cone angle of the measurement used (NaN coasted)", False),
        "meas_port_deg": _c("deg", "its port bearing", False),
        "meas_stbd_deg": _c("deg", "its starboard bearing", False),
        "meas_freq_hz": _c("Hz", "its frequency (NaN broadband or coasted)", False),
        "meas_tonal": _c("", "tonal slot its frequency updated (-1 none)", False, "i8"),
        "f_hz": _c("Hz", "received frequency of each tonal slot of the track, (n, K); NaN "
                   "empty", False, trailing=_ANY),
        "sigma_f_hz": _c("Hz", "1-sigma of f_hz, (n, K)", False, trailing=_ANY),
        # fused_bearings tracks (track/multi/fused.py): the array of each point's measurement
        "array": _c("", "input (array) whose row updated the point, index of the group "
                    "attributes array_x_m / array_y_m (-1 coasted)", False, "i8"),
        "meas_azimuth_deg": _c("deg", "azimuth of the measurement used (NaN coasted)", False),
    }),
    Kind("tma", "batch solution", {
        "t0": _c("s", "window start (reference time of the state)"),
        "t1": _c("s", "window end"),
        "method": _c("", "bearings, bearings_frequency, delays, compact or cross_fix",
                     dtype="S20"),
        "x": _c("m", "east"), "y": _c("m", "north"),
        "vx": _c("m/s", "east velocity"), "vy": _c("m/s", "north velocity"),
        "cov": _c("m², m²/s²", "covariance of the estimate, (n, 4, 4)", trailing=(4, 4),
                  dims=_STATE),
        "crlb": _c("m², m²/s²", "Cramér-Rao bound, (n, 4, 4)", trailing=(4, 4), dims=_STATE),
        "cost": _c("", "negative log-likelihood at the solution"),
        "fim_cond": _c("", "condition number of the Fisher information (eq. 3.54)"),
        "heading_deg": _c("deg", "target course"),
        "speed_mps": _c("m/s", "target speed"),
        "range_sigma_m": _c("m", "range standard deviation from the CRLB (eq. 3.55)", False),
        "cost_mirror": _c("", "cost of the mirrored side hypothesis", False),
        "preferred": _c("", "1: the solution the data prefer; 0: its mirror (sides flipped), "
                        "written while the manoeuvre has not resolved the side", False,
                        dtype="i1"),
        # one solution per track (a tracks file's input)
        "track_id": _c("", "the track solved (its rows in the tracks file)", False,
                       dtype="i8"),
        "pair_track_id": _c("", "cross_fix of two tracks files: the second array's track "
                            "paired with track_id", False, dtype="i8"),
        "f0_hz": _c("Hz", "rest frequency of the tonal (bearings_frequency)", False),
        "sigma_f0_hz": _c("Hz", "CRLB standard deviation of f0_hz", False),
        "n_used": _c("", "measurement rows used", False, dtype="i8"),
        # compact: the bearing errors' exponential correlation time
        "tau_s": _c("s", "compact: correlation time of the bearing errors used (configured, "
                    "or estimated from the residuals)", False),
        "tau_sigma_s": _c("s", "compact: standard error of an estimated tau_s (NaN: "
                          "configured)", False),
    }),
]

KINDS: dict[str, Kind] = {k.name: k for k in _KINDS}


def kind(name: str) -> Kind:
    """The declared kind ``name``.

    Parameters
    ----------
    name : str
        Product kind, e.g. ``"bearings"``.

    Returns
    -------
    Kind

    Raises
    ------
    FormatError
        When the kind is not declared.
    """
    try:
        return KINDS[name]
    except KeyError:
        raise FormatError(f"unknown product kind {name!r} (known: "
                          f"{', '.join(sorted(KINDS))})") from None


def check_columns(kind_name: str, names: set[str] | list[str], where: str = "") -> None:
    """Raise FormatError if a dataset name is not declared for the kind.

    Parameters
    ----------
    kind_name : str
        Product kind.
    names : iterable of str
        Dataset names to be written.
    where : str
        Group name for the message.
    """
    k = kind(kind_name)
    extra = sorted(set(names) - k.names())
    if extra:
        raise FormatError(f"{where or kind_name}: column(s) {', '.join(extra)} are not declared "
                          f"for kind {kind_name!r} (arrayproc.io.schema)")


def check_group(name: str, group: Mapping[str, Any], path: str = "") -> None:
    """Raise FormatError if a read group misses a required column of its kind.

    Parameters
    ----------
    name : str
        Group name.
    group : mapping
        The group as read (``kind`` and its datasets).
    path : str
        File, for the message.
    """
    k = KINDS.get(str(group.get("kind", "")))
    if k is None:
        return  # a kind written by a newer version: described, not interpreted
    missing = [c for c in k.required() if c not in group]
    n_rows = {group[c].shape[0] for c in k.columns if c in group
              and getattr(group[c], "ndim", 0) >= 1}
    if missing and any(n > 0 for n in n_rows):
        raise FormatError(f"{path}: group {name!r} (kind {k.name!r}) lacks column(s) "
                          f"{', '.join(missing)}")


def empty_columns(kind_name: str) -> dict[str, Any]:
    """The required columns of a kind with no rows, each of its declared dtype and dimensions
    (trailing sizes 0 when they are not known): what a group that found nothing holds, so that
    every reader sees a valid empty table.

    Parameters
    ----------
    kind_name : str
        Product kind.

    Returns
    -------
    dict
        ``{column: ndarray of shape (0, …)}``.
    """
    k = kind(kind_name)
    return {n: np.zeros((0,) + tuple(t or 0 for t in c.trailing), c.dtype)
            for n, c in k.columns.items() if c.required}


def groups_of_kind(groups: Mapping[str, Mapping[str, Any]], kind_name: str) -> list[str]:
    """Names of the groups of one kind in a products file read by ``read_products``, in file
    order (the kind attribute as ``str`` or ``bytes``); the filter behind
    :meth:`arrayproc.io.products.ProductsFile.groups`.

    Parameters
    ----------
    groups : mapping
        ``{name: group}`` as returned by :func:`arrayproc.io.products.read_products`.
    kind_name : str
        Product kind.

    Returns
    -------
    list of str
    """
    return [n for n, g in groups.items() if n != "/" and as_text(g.get("kind")) == kind_name]


def markdown_table() -> str:
    """The products table of docs/formats.md, made from the declarations above.

    Returns
    -------
    str
        A Markdown table: kind, one row per, columns (required plain, optional in italics, each
        with its unit) and axes; one line per kind, in declaration order.
    """
    def cells(cols: Mapping[str, Column]) -> str:
        out = []
        for n, c in cols.items():
            name = f"`{n}`" if c.required else f"*`{n}`*"
            out.append(f"{name} {c.unit}".rstrip())
        return ", ".join(out) if out else "—"

    lines = ["| kind | one row per | columns (required; *optional*) | axes |",
             "| --- | --- | --- | --- |"]
    for k in KINDS.values():
        axes = ", ".join(f"`{n}`" for n in k.axes) if k.axes else "—"
        lines.append(f"| `{k.name}` | {k.row} | {cells(k.columns)} | {axes} |")
    return "\n".join(lines)
