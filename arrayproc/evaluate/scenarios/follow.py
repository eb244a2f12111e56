"""The followed-recording set-up: the chain that ``process --follow`` runs on the live
recorder's file (8 hydrophones at 1 kHz), in the follow tests and the latency bench."""

from __future__ import annotations

from pathlib import Path

from arrayproc.evaluate.chains import cbf_stage, chain_toml

__all__ = ["BLOCK", "follow_chain"]

BLOCK = 512  # samples per block of the followed chain


def follow_chain(directory: Path) -> Path:
    """Write the chain (CBF of 256-sample snapshots in batches of 2, sliding integration of
    2, BTR and LOFAR) as ``directory``/chain.toml; returns its path."""
    c = Path(directory) / "chain.toml"
    c.write_text(chain_toml(cbf_stage(256, [80.0, 200.0], 19, batch=2), {"type": "integrate",
                            "snapshots": 2, "mode": "sliding"},
                            {"type": "btr", "band": [110.0, 130.0]},
                            {"type": "lofar", "input": "integrate", "beams": [60.0]},
                            block=BLOCK))
    return c
