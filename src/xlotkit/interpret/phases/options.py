"""The segmentation's options: every one a fraction, a multiple or a sample count.

No option is a pressure, a rate or a time in physical units. Pressures are compared with the
record's own noise and its pressure span above the pre-test level, rates with the record's
own rate scale, speeds of rise and fall with other rises and falls of the same record, and
windows are counted in samples of the record's *resolution*: its own sampling interval, or a
fraction ``1 / time_resolution`` of its duration where it is logged more coarsely than that
(:meth:`SegmentOptions.for_sampling`). A log written in other units, or the same test run at
another pressure, rate or speed, is segmented the same way
(``tests/interpret/test_phases_units.py``), and so is the same log decimated
(``tests/interpret/test_phases_sampling.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from xlotkit.errors import InputError

__all__ = ["SegmentOptions"]

#: Options that are fractions strictly between 0 and 1.
_FRACTIONS = ("pump_on", "pump_off", "return_on", "return_off", "idle_fraction",
              "leg_fraction", "cycle_fraction", "release_fraction", "restart_fraction",
              "bleed_fraction", "partial_release_fraction", "fast_release",
              "release_levelling", "unmetered_steepness",
              "rise_steepness", "rise_linearity", "rise_levelling", "rough_fraction",
              "step_fraction", "line_test_volume", "departure_tolerance", "xlot_fall",
              "hold_max_drop", "rate_step_change", "rate_step_stable", "base_dwell_fraction")
#: Options that are whole numbers of samples (>= 1).
_SAMPLES = ("smooth_samples", "slope_half", "rate_filter_samples", "gap_samples",
            "min_pump_samples", "min_phase_samples", "settle_samples", "min_rate_steps",
            "time_resolution", "min_return_samples")
#: The windows: sample counts that stand for a stretch of time (``min_rate_steps`` counts
#: rate steps, not samples), with the fewest samples each can shrink to on a coarse log
#: (a median needs 3 samples to drop a spike; a phase needs 2 samples to have a slope).
_WINDOWS = {"smooth_samples": 1, "slope_half": 1, "rate_filter_samples": 1,
            "gap_samples": 1, "min_pump_samples": 2, "min_phase_samples": 2,
            "settle_samples": 2, "min_return_samples": 2}
#: Windows of running medians, kept odd when scaled.
_ODD = ("smooth_samples", "rate_filter_samples")


@dataclass(frozen=True)
class SegmentOptions:
    """Options of :func:`xlotkit.interpret.phases.segment` (docs/field/segmentation.md).

    Scales of the record (:class:`~xlotkit.interpret.phases.types.RecordScales`): ``noise``
    (pressure noise), ``base`` (pre-test level), ``span`` (highest pressure above base),
    ``rate_scale`` (high percentile of the metered pump rate).

    Attributes
    ----------
    smooth_samples : int
        Running-median window of the pressure [samples] [7].
    slope_half : int
        Half-width of the centred difference giving dp/dt [samples] [4].
    rate_filter_samples : int
        Running-median window of the rates, so one-sample spikes and dropouts do not start
        or stop a phase [samples] [5].
    gap_samples : int
        Pauses in pumping or returns up to this long are bridged [samples] [10].
    min_pump_samples : int
        Shortest metered pump phase kept [samples] [10].
    min_phase_samples : int
        Shortest shut-in / flowback / idle phase kept; shorter ones join a neighbour
        [samples] [15].
    min_return_samples : int
        Shortest run of returns that is a flowback; a shorter one is a valve cycled [30].
    settle_samples : int
        Samples after a pump stop before its shut-in decline is read, and before a pump
        start that give the level it started from [20].
    pump_on, pump_off : float
        Pump rate above which pumping starts and below which it stops (hysteresis), as
        fractions of ``rate_scale`` [0.03, 0.015].
    return_on, return_off : float
        The same for the return rate (and the growth of a return volume), as fractions of
        the pump rate scale (of the return rate scale when no pump rate is logged)
        [0.03, 0.015].
    noise_multiple : float
        A pressure change is real only beyond this many ``noise`` [6].
    idle_fraction : float
        The well is idle below ``base + max(noise_multiple noise, idle_fraction span)``
        [0.015].
    leg_fraction : float
        Rises and falls of the pressure are its legs reversing by at least
        ``max(noise_multiple noise, leg_fraction span)`` [0.04].
    cycle_fraction : float
        A cycle raises the pressure at least ``cycle_fraction span`` above both the base and
        the level its pumping started from [0.1]; pumping that builds less is a flush or
        circulation.
    release_fraction : float
        A pump phase opens a new cycle when, since the peak of the current one, the
        pressure has come down to within this fraction of that peak's height above base
        (or to the idle band); otherwise it is a stage or top-up of the current one [0.5].
    restart_fraction : float
        A pump phase from a shut-in well that pumps at least this fraction of the volume
        (without a rate: of the pumping time) the current cycle has pumped so far opens a
        new cycle: a second pressurisation, not a top-up [0.25].
    bleed_fraction : float
        A release (bleed / flowback) takes away at least this fraction of the pressure above
        base [0.6]; smaller fast falls (the step at pump stop) stay shut-in unless they are
        a partial release (``partial_release_fraction``).
    partial_release_fraction : float
        A smaller fall, taking at least this fraction of the pressure above base, is a
        partial release (a valve opened and shut again) when it starts abruptly from a
        shut-in whose own decline it outpaces ``acceleration`` times and ends abruptly
        (it does not die away like leak-off) [0.05].
    acceleration : float
        A fall is a release when it is this many times faster than the decline of the
        shut-in just before it: leak-off only slows down [3].
    release_levelling : float
        A fall dies away like leak-off (exponentially, towards the formation's pressure)
        rather than like flow out through a valve or choke when its rate takes more than
        this fraction of the time to its tenth to go from half to a tenth [0.55]
        (exponential 0.70, choke 0.44, valve: abrupt).
    fast_release : float
        A fall that starts at pump stop is a release when it reaches base in less than this
        fraction of the pumping time [0.1].
    unmetered_steepness : float
        With a pump rate logged, a rise while no rate is metered is pumping (a line-test
        pump) when it is about linear and, at its steepest, at least this fraction as steep
        as the steepest rise of the record's metered pumping [0.5]; a slower rise is a
        shut-in well recovering after a release.
    rise_steepness : float
        Without a pump rate, a rise is pumping when its mean slope is at least this fraction
        of the steepest rise of the record [0.02]; a gauge run in the hole rises far slower.
    rise_linearity : float
        Pumping at constant rate raises pressure about linearly in time, a shut-in well
        recovering after a bleed rises fast first and then levels off: a rise is pumping only
        if it takes at least this fraction of its duration to make half its gain [0.3].
    rise_levelling : float
        A pump stops, a recovering well levels off: on a pumping rise, dp/dt falls from half
        its maximum to a tenth of it within this fraction of the rise's duration (or within
        the smoothing windows) [0.35].
    rough_multiple, rough_fraction : float
        Without a rate, the pressure pulses while the pump runs: where its local
        sample-to-sample noise (over ``2 settle_samples``) exceeds ``rough_multiple`` times
        the record's noise and ``rough_fraction`` of the span, the pump runs on [5, 0.001].
    step_fraction : float
        Without a rate, the pump stop at the end of a propagation plateau is a sudden fall of
        at least this fraction of the pressure above base (and ``noise_multiple`` noise)
        [0.05].
    step_contrast : float
        A sudden fall is this many times the fall just before and just after it [3].
    line_test_volume : float
        A cycle pressurised with less than this fraction of the largest volume pumped to a
        cycle's peak in the record is a line test (lines against a closed valve take almost
        nothing) [0.005].
    line_test_stiffness : float
        So is a cycle pressurised with less than ten times that fraction whose stiffness
        dp/dV is this many times that of the softest other cycle [20].
    departure_tolerance : float
        Fall below the early linear p-V trend, as a fraction of the pressure gain, that
        counts as a departure from linearity (leak-off) [0.05].
    xlot_fall : float
        Fall of pressure while still pumping, as a fraction of the gain, that marks a
        breakdown / propagation [0.05].
    xlot_past_ratio : float
        Volume pumped past the departure, relative to the volume up to it, beyond which a
        cycle is an XLOT rather than a LOT [0.5].
    hold_ratio : float
        A hold (casing test) is read over the shut-in up to this multiple of the pumping time
        after pump stop [3].
    min_hold_ratio : float
        Shortest hold that makes a pressure test, as a multiple of the pumping time [1].
    hold_max_drop : float
        Largest fall over the hold, as a fraction of the pressure above base, for a test to
        count as held [0.1].
    dfit_falloff_ratio : float
        A cycle with one injection past leak-off and no flowback whose shut-in lasts at least
        this multiple of the injection time is a DFIT / mini-frac [5].
    min_rate_steps : int
        Fewest rate steps of a step-rate test or a stimulation [4]: the fracture-extension
        pressure is the break between two lines through the steps, at least two on each.
    rate_step_change : float
        Rate levels differ when they differ by this fraction of the cycle's highest rate
        [0.05].
    rate_step_stable : float
        A step is stabilised when the pressure moves over its last third by at most this
        fraction of the pressure change into it (or a tenth of the cycle's gain), beyond
        three standard errors of that movement [0.1]: relaxing exponentially, a step has
        then lasted about three time constants (95 % of the way to its steady level).
    base_dwell_fraction : float
        A record that starts pressurised has as base the lowest level where it dwells at
        least this fraction of its length [0.05].
    time_resolution : int
        The windows above are counted in samples of a record logged at least this finely
        over its duration [1500]; a coarser log (a 10 s or 30 s decimation of the same test)
        counts them in time, ``duration / time_resolution`` per sample, so that no window
        grows longer in time than on the fine log: a 15-sample minimum phase at 30 s would
        be 7.5 minutes and swallow a whole flowback (:meth:`for_sampling`).
    """

    smooth_samples: int = 7
    slope_half: int = 4
    rate_filter_samples: int = 5
    gap_samples: int = 10
    min_pump_samples: int = 10
    min_phase_samples: int = 15
    settle_samples: int = 20
    min_return_samples: int = 30
    pump_on: float = 0.03
    pump_off: float = 0.015
    return_on: float = 0.03
    return_off: float = 0.015
    noise_multiple: float = 6.0
    idle_fraction: float = 0.015
    leg_fraction: float = 0.04
    cycle_fraction: float = 0.1
    release_fraction: float = 0.5
    restart_fraction: float = 0.25
    bleed_fraction: float = 0.6
    partial_release_fraction: float = 0.05
    acceleration: float = 3.0
    release_levelling: float = 0.55
    fast_release: float = 0.1
    unmetered_steepness: float = 0.5
    rise_steepness: float = 0.02
    rise_linearity: float = 0.3
    rise_levelling: float = 0.35
    rough_multiple: float = 5.0
    rough_fraction: float = 0.001
    step_fraction: float = 0.05
    step_contrast: float = 3.0
    line_test_volume: float = 0.005
    line_test_stiffness: float = 20.0
    departure_tolerance: float = 0.05
    xlot_fall: float = 0.05
    xlot_past_ratio: float = 0.5
    hold_ratio: float = 3.0
    min_hold_ratio: float = 1.0
    hold_max_drop: float = 0.1
    dfit_falloff_ratio: float = 5.0
    min_rate_steps: int = 4
    rate_step_change: float = 0.05
    rate_step_stable: float = 0.1
    base_dwell_fraction: float = 0.05
    time_resolution: int = 1500

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"must be a finite number, got {v!r}", key=f.name)
            if v <= 0:
                raise InputError(f"must be > 0, got {v!r}", key=f.name)
        for name in _FRACTIONS:
            if not 0.0 < getattr(self, name) < 1.0:
                raise InputError(f"must be between 0 and 1, got {getattr(self, name)!r}",
                                 key=name)
        for name in _SAMPLES:
            v = getattr(self, name)
            if v != int(v) or v < 1:
                raise InputError(f"must be a whole number of samples >= 1, got {v!r}",
                                 key=name)
        for on, off in (("pump_on", "pump_off"), ("return_on", "return_off")):
            if getattr(self, off) > getattr(self, on):
                raise InputError(f"must not exceed {on} ({getattr(self, on)!r})", key=off)
        if self.partial_release_fraction > self.bleed_fraction:
            raise InputError(f"must not exceed bleed_fraction ({self.bleed_fraction!r}), got "
                             f"{self.partial_release_fraction!r}",
                             key="partial_release_fraction")
        for name in ("acceleration", "step_contrast", "line_test_stiffness", "rough_multiple"):
            if getattr(self, name) <= 1.0:
                raise InputError(f"must be > 1, got {getattr(self, name)!r}", key=name)

    def for_sampling(self, dt: float, duration: float) -> SegmentOptions:
        """These options with the windows counted in samples of a record's own sampling.

        A window of ``n`` samples stands for ``n`` sampling intervals of a log that resolves
        the record's ``duration`` into at least ``time_resolution`` samples. A log sampled
        at ``dt`` coarser than ``duration / time_resolution`` gets ``n`` times that interval
        in time, i.e. ``n * duration / (time_resolution * dt)`` of its own samples (never
        fewer than the window's floor); a finer log keeps ``n`` samples. Decimating a record
        thus leaves every window the same length in time once the log is coarse, and a
        test run faster or slower (time scaled) keeps the same windows in samples.

        Parameters
        ----------
        dt : float
            The record's median sampling interval [s].
        duration : float
            The record's duration [s].

        Returns
        -------
        SegmentOptions
        """
        if not (dt > 0 and duration > 0 and math.isfinite(dt) and math.isfinite(duration)):
            return self
        factor = duration / (self.time_resolution * dt)
        if factor >= 1.0:
            return self
        new = {name: max(floor, round(getattr(self, name) * factor))
               for name, floor in _WINDOWS.items()}
        for name in _ODD:  # a running median's window stays centred: odd
            if getattr(self, name) % 2 == 1 and new[name] % 2 == 0:
                new[name] = new[name] + 1 if getattr(self, name) * factor > new[name] \
                    else new[name] - 1
            new[name] = max(new[name], 1)
        return replace(self, **new)
