"""Narrowband bearing/frequency tracker: the EKF of thesis eqs. (3.21)-(3.23) with regular
re-initialisation and two staggered filters (thesis 3.2.1.1, fig. 3.6), amplitude compensated
as in thesis 3.2.1.3.

Re-initialisation: the frequency column of the Jacobian grows with the time since the filter's
start (eq. (3.23), fig. 3.5), which freezes the frequency estimate; so every ``reinit_s``
seconds a filter restarts: its time origin moves to now, its covariance returns to ``P0`` and
its state is set to the current output ("even with the right parameters", the thesis notes a
ripple follows). With ``dual``, a second filter restarts half a period later and the output is
taken from the filter that has run longer since its last restart, i.e. the one out of its
start-up ripple (fig. 3.6, right).

Phase alignment (``align_phase``, default on; off is the thesis's re-initialisation): the state
has no phase, so a filter started with time origin "now" sees the tonal's phase offset as a
frequency error φ0 / (2π τ) that decays as 1/τ (the start-up ripple), and at high SNR the first
large updates can throw the cone onto a sidelobe. With alignment, the time origin of a
re-initialised filter is moved by less than one period 1/f_D so that its model phase equals
that of the filter it is re-initialised from (which is locked to the data); the first start
takes the phase from the data (the element samples correlated with the model's phasors over
the first ``ALIGN_S`` seconds). The model and the state are the thesis's; only the time origin
changes.

Amplitude: per input block, the tonal power A² and the noise power are split with the array
(:mod:`.amplitude`) at the current estimate, smoothed over ``amp_tau_s`` seconds, and the
samples are divided by A before the update; the EKF's measurement variance is then the noise
variance over A² (or ``noise`` / A² when the user gives it).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from arrayproc.stages.narrowband import _kernels
from arrayproc.stages.narrowband.amplitude import analytic, split_power
from arrayproc.stages.narrowband.model import phase

#: Span of the first samples whose phase aligns the first start, s.
ALIGN_S = 0.1


@dataclass
class _Filter:
    state: np.ndarray  # (θ rad, f Hz)
    cov: np.ndarray  # (2, 2)
    origin: float  # time of the last (re)initialisation, s
    next_reinit: float  # s


class NarrowbandEKF:
    """One or two staggered, regularly re-initialised EKFs on a line array's samples.

    Parameters
    ----------
    x : (N,) ndarray
        Element positions along the body x axis, m (forward positive); the cone is that of
        the plane wave at the array centre.
    cone_deg, freq_hz : float
        Initial cone angle (deg, 0 forward end-fire) and tonal frequency (Hz, without own
        Doppler).
    sound_speed : float
        m/s.
    fc : float or None
        Baseband mixing frequency (Hz) of complex input; None for real input.
    p0 : (float, float)
        Initial standard deviations of cone (deg) and frequency (Hz).
    q : (float, float)
        Process noise: random-walk standard deviations of cone (deg/√s) and frequency (Hz/√s).
    noise : float or None
        Measurement noise power of the input samples (real: variance per sample; complex:
        E|v|²), input units²; None to estimate it with the amplitude.
    reinit_s : float
        Re-initialisation period of each filter, s.
    dual : bool
        Run two filters staggered by half a period (thesis fig. 3.6).
    amp_tau_s : float
        Smoothing time constant of the amplitude/noise estimates, s.
    align_phase : bool
        Choose each (re)start's time origin so that the model phase matches (see the module
        docstring); False re-initialises with the origin at the restart time (the thesis).
    spatial_doppler : bool
        Own-speed Doppler factor on the element delay term too (thesis eq. (3.18)); False:
        on the time term only, the exact plane-wave phase (see :mod:`.model`).
    threads : int
        With ``dual``, run the two filters of each span in two threads (the kernel releases
        the GIL; the filters are independent between re-initialisations, so the output is
        the same).
    """

    def __init__(self, x: np.ndarray, cone_deg: float, freq_hz: float, sound_speed: float,
                 fc: float | None = None, p0: tuple[float, float] = (2.0, 0.5),
                 q: tuple[float, float] = (0.05, 0.01), noise: float | None = None,
                 reinit_s: float = 30.0, dual: bool = True, amp_tau_s: float = 5.0,
                 align_phase: bool = True, threads: int = 1,
                 spatial_doppler: bool = True) -> None:
        # positions from the array centre: the model's common phase then refers to the centre,
        # where a cone error adds no phase (any reference is a constant phase for eq. (3.21))
        x = np.asarray(x, float)
        self.x = np.ascontiguousarray(x - 0.5 * (x.min() + x.max()))
        d = np.diff(self.x)
        self.uniform = bool(d.size == 0 or np.allclose(d, d[0], rtol=1e-9, atol=1e-12))
        self.c = float(sound_speed)
        self.fc = fc
        self.p0 = np.diag([math.radians(p0[0]) ** 2, float(p0[1]) ** 2])
        self.q = np.array([math.radians(q[0]) ** 2, float(q[1]) ** 2])
        self.noise = noise
        self.reinit_s = float(reinit_s)
        self.dual = bool(dual)
        self.amp_tau_s = float(amp_tau_s)
        self.align_phase = bool(align_phase)
        self.spatial_doppler = bool(spatial_doppler)
        self._pool = (ThreadPoolExecutor(2) if self.dual and threads > 1 else None)
        self._x0 = np.array([math.radians(cone_deg), float(freq_hz)])
        self._filters: list[_Filter] | None = None
        self._a2: float | None = None
        self._s2: float | None = None

    def _start(self, t: float) -> None:
        self._filters = [_Filter(self._x0.copy(), self.p0.copy(), t, t + self.reinit_s)]
        if self.dual:
            self._filters.append(_Filter(self._x0.copy(), self.p0.copy(), t,
                                         t + 0.5 * self.reinit_s))

    def _align_start(self, y: np.ndarray, t0: float, fs: float, speed: float) -> None:
        """Move the first start's time origin so that the model phase matches the data."""
        n = max(1, min(y.shape[0], int(round(ALIGN_S * fs))))
        th, f = self._x0
        tau = np.arange(n) / fs
        ph = np.stack([phase(th, f, tk, self.x, speed, self.c, self.spatial_doppler)
                       for tk in tau])
        if self.fc is not None:
            ph = ph - self._mix(t0, fs, n)[:, None]
            r = np.sum(y[:n] * np.exp(-1j * ph))
        else:  # analytic of sin Φ is −j e^{jΦ}
            r = np.sum(1j * analytic(y)[:n] * np.exp(-1j * ph))
        fd = f * (1.0 + speed * math.cos(th) / self.c)
        shift = (np.angle(r) / (2.0 * np.pi)) % 1.0 / fd
        for flt in self._filters:
            flt.origin = t0 - shift

    def _mix(self, t0: float, fs: float, n: int) -> np.ndarray:
        """Mixing phase 2π fc t (rad) of n samples from t0 (reduced modulo one cycle)."""
        return 2.0 * np.pi * np.mod(self.fc * (t0 + np.arange(n) / fs), 1.0)

    def _active(self) -> int:
        """Index of the filter that has run longest since its last restart."""
        ages = [-f.origin for f in self._filters]
        return int(np.argmax(ages))

    @property
    def estimate(self) -> tuple[float, float]:
        """Current output (cone deg, frequency Hz)."""
        f = self._filters[self._active()] if self._filters else None
        s = f.state if f is not None else self._x0
        return math.degrees(s[0]), float(s[1])

    def _amplitude(self, y: np.ndarray, speed: float, span: float) -> tuple[float, float]:
        th, f = (self._filters[self._active()].state if self._filters else self._x0)
        fd = f * (1.0 + speed * math.cos(th) / self.c)
        steer = np.exp(-2j * np.pi * fd * self.x * math.cos(th) / self.c)
        a2, s2 = split_power(analytic(y), steer)
        if self._a2 is None:
            self._a2, self._s2 = a2, s2
        else:
            w = 1.0 - math.exp(-span / self.amp_tau_s)
            self._a2 += w * (a2 - self._a2)
            self._s2 += w * (s2 - self._s2)
        if self.noise is not None:  # user's noise power: the amplitude from the excess
            pe = self._a2 + self._s2
            nz = self.noise if self.fc is not None else 2.0 * self.noise
            return max(pe - nz, 1e-6 * pe), nz
        return self._a2, self._s2

    def process(self, y: np.ndarray, t0: float, fs: float, speed: float) -> dict[str, np.ndarray]:
        """Track through one block of samples.

        Parameters
        ----------
        y : (T, N) ndarray, real or complex
            DFT-filtered element samples (complex: baseband mixed down by ``fc``).
        t0 : float
            Time of the first sample, s.
        fs : float
            Sample rate, Hz.
        speed : float
            Own speed along the array axis, m/s.

        Returns
        -------
        dict of (T,) ndarrays
            ``time`` s, ``cone_deg``, ``freq_hz``, ``sigma_cone_deg``, ``sigma_freq_hz``,
            ``filter`` (index of the filter giving the output), ``amplitude`` (input units).
        """
        n_t = y.shape[0]
        first = self._filters is None
        if first:
            self._start(t0)
            if self.align_phase:
                self._align_start(y, t0, fs, speed)
        a2, s2 = self._amplitude(y, speed, n_t / fs)
        amp = math.sqrt(a2)
        cplx = np.iscomplexobj(y)
        yr = np.ascontiguousarray(y.real / amp, float)
        yi = np.ascontiguousarray(y.imag / amp, float) if cplx else np.zeros((1, 1))
        # noise variance per real measurement component, in units of A²
        r = 0.5 * s2 / a2
        rinv = np.full(self.x.size, 1.0 / max(r, 1e-12))
        fc = float(self.fc or 0.0)
        dt = 1.0 / fs
        mix_step = 2.0 * math.pi * fc * dt
        res = np.empty((n_t, 4))
        which = np.empty(n_t, np.int8)
        outs = [np.empty((n_t, 4)) for _ in self._filters]
        k = 0
        while k < n_t:
            t_k = t0 + k * dt
            nxt = min(f.next_reinit for f in self._filters)
            k1 = min(n_t, max(k + 1, int(math.ceil((nxt - t0) * fs - 1e-9))))
            mix0 = 2.0 * math.pi * math.fmod(fc * t_k, 1.0)

            def span(f: _Filter, o: np.ndarray, k=k, k1=k1, t_k=t_k, mix0=mix0) -> None:
                _kernels.ekf_span(yr[k:k1], yi[k:k1] if cplx else yi, cplx, t_k - f.origin,
                                  dt, speed, self.x, self.c, mix0, mix_step, rinv, self.q,
                                  f.state, f.cov, o[k:k1], self.uniform,
                                  1.0 if self.spatial_doppler else 0.0)

            if self._pool is not None:
                for fut in [self._pool.submit(span, f, o) for f, o in zip(self._filters, outs)]:
                    fut.result()
            else:
                for f, o in zip(self._filters, outs):
                    span(f, o)
            i = self._active()
            res[k:k1] = outs[i][k:k1]
            which[k:k1] = i
            k = k1
            t_next = t0 + k * dt
            for j, f in enumerate(self._filters):
                if t_next >= f.next_reinit - 1e-9:
                    src = self._filters[self._active_excluding(j)]
                    f.state = src.state.copy()
                    f.cov = self.p0.copy()
                    if self.align_phase:  # same model phase as src, origin within 1/f_D
                        fd = src.state[1] * (1.0 + speed * math.cos(src.state[0]) / self.c)
                        f.origin = t_next - math.fmod(t_next - src.origin, 1.0 / fd)
                    else:
                        f.origin = t_next
                    f.next_reinit += self.reinit_s
        return {"time": t0 + np.arange(n_t) * dt, "cone_deg": np.degrees(res[:, 0]),
                "freq_hz": res[:, 1], "sigma_cone_deg": np.degrees(np.sqrt(res[:, 2])),
                "sigma_freq_hz": np.sqrt(res[:, 3]), "filter": which,
                "amplitude": np.full(n_t, amp)}

    def _active_excluding(self, j: int) -> int:
        """The filter whose state re-initialises filter ``j``: the other one when dual."""
        if len(self._filters) == 1:
            return 0
        return 1 - j
