"""Processing chains: stages (generator transforms over blocks), their registry, the TOML
builder that validates a whole chain before any data is read, and the runner.

A chain file looks like::

    [input]
    block = 8192            # samples per time block read from the recording (default 8192)

    [[stage]]
    type = "dft_filter"
    band = [100.0, 2000.0]

    [[stage]]
    type = "cbf"
    name = "cbf"
    nfft = 2048

    [[stage]]
    type = "power"
    input = "dft_filter"    # a branch reading the same upstream as cbf

Each stage reads the stage before it unless it names an ``input``. The reader feeds
non-overlapping time blocks of ``block`` samples; stages that need overlapping frames
(FFT-based ones) frame the stream themselves with ``dsp.framing.FrameBuffer``, so block boundaries
never show in the results.

Segments: :func:`run_chain` accepts ``t_start``/``t_stop``; it reads from a warm-up margin
before the start to the same margin after the stop (the sum of the stages' ``warmup_seconds``
along the longest path, each at its input rate) and the products writer keeps only rows whose
time falls in the segment, so independent segments (e.g. on Dask workers) concatenate into the
result of one long run.
"""


from arrayproc.chain.block import Block, Pose
from arrayproc.chain.graph import ChainSpec, build_chain, compose, drive, set_rates
from arrayproc.chain.run import run_chain
from arrayproc.chain.segments import warmup_margin
from arrayproc.chain.stage import STAGES, RunContext, Stage, register
from arrayproc.config import Param, positive

__all__ = ["Block", "ChainSpec", "Param", "Pose", "RunContext", "STAGES", "Stage", "build_chain",
           "compose", "drive", "positive", "register", "run_chain", "set_rates",
           "warmup_margin"]
