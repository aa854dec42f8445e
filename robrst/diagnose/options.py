"""The diagnosis's tuning constants, gathered in frozen option records (one line each on why).

Every threshold, budget and grid the diagnosis uses lives here, grouped by the stage that
reads it; the modules read :data:`OPTIONS` (the defaults) and hold no tuning constant of
their own.  The records are frozen: a study of another setting builds its own with
:func:`dataclasses.replace` and passes it where a function takes ``options``.

* :class:`RecordOptions` — what records a diagnosis accepts and what they excite;
* :class:`NoiseOptions` — the noise floor and where the gap lies (time, frequency, FRF,
  residual tests);
* :class:`SensorOptions` — outliers and dropouts of the sensor;
* :class:`LevelOptions` — excitation levels and the amplitude finding;
* :class:`LinearOptions` — the linear part's corrections (priors, bounds, excitation);
* :class:`EffectOptions` — the effect library's data-derived grids and stability bounds;
* :class:`FitOptions` — the nonlinear least-squares fits and their budgets;
* :class:`ScreenOptions` — the exact linear screen's columns and grids;
* :class:`SelectOptions` — the forward selection, credit by removal and ties;
* :class:`VerdictOptions` — the verdict's bars and the findings;
* :class:`DiagnoseOptions` — all of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["RecordOptions", "NoiseOptions", "SensorOptions", "LevelOptions", "LinearOptions",
           "EffectOptions", "FitOptions", "ScreenOptions", "SelectOptions", "VerdictOptions", "DiagnoseOptions",
           "OPTIONS"]


@dataclass(frozen=True)
class RecordOptions:
    """What records a diagnosis accepts and what they excite.

    Attributes
    ----------
    min_samples : int
        Samples per record at least.
    temp_excited_K : float
        A temperature range below this does not excite the thermal effects [K].
    excited_ptp : float
        An input or temperature range above this is an excitation.
    level_ratio : float
        Two excitation levels are distinct when the higher is this factor above the lower.
    repeat_rtol : float
        A record without ``period_samples`` is periodic when its input repeats to this
        share of its RMS (or to two quantisation steps) ...
    repeat_temp_K : float
        ... and its temperature to this [K] ...
    min_period : int
        ... with a period of at least this many samples.
    """

    min_samples: int = 500        # fewer samples hold too little of the slowest mode to fit
    temp_excited_K: float = 0.05  # below the resolution of the drift and thermal laws
    excited_ptp: float = 1e-6     # a constant column written with rounding is not moved
    level_ratio: float = 1.3      # 30 % apart: a level-dependent gap shows over the noise
    repeat_rtol: float = 2e-3     # a measured multisine repeats to 4e-4 of its RMS; an input
    # that is not periodic differs by tens of % between two stretches
    repeat_temp_K: float = 0.01   # a thermocouple's resolution: a ramp is not periodic
    min_period: int = 32          # shorter "periods" are a constant input's, not an excitation


@dataclass(frozen=True)
class NoiseOptions:
    """The noise floor and where the gap lies.

    Attributes
    ----------
    bands : tuple of (float, float)
        Sub-bands (fractions of Nyquist) of the spectral floor; the smallest median wins.
    excited_rel : float
        A frequency bin is excited when the input's power there exceeds this share of its
        largest; excited bins never count as noise.
    min_unexcited : float
        A sub-band counts when at least this share of its bins is not excited.
    period_blocks : int
        Blocks per period of the period differences (the median of their mean squares) ...
    min_block : int
        ... of at least this many samples.
    window_factor : float
        A time window is reported where the moving RMS exceeds this many noise levels.
    max_windows : int
        Time windows reported at most.
    band_factor : float
        A frequency bin counts when its PSD exceeds this many white-noise levels.
    band_quantiles : (float, float)
        The band runs between these quantiles of the excess energy.
    max_lag : int
        Lags of the whiteness and cross-correlation tests.
    test_level : float
        Significance of those tests (Bonferroni-corrected over the lags).
    max_coherence : float
        The FRF's coherence is capped here (its standard error would vanish).
    min_coherence : float
        FRF bins with less coherence are not compared.
    frf_sigmas : float
        An FRF bin departs when its error exceeds this many standard errors.
    regime_bins : int
        Bins of the correlation ratio of the regime variables.
    """

    bands: tuple = ((0.3, 0.45), (0.45, 0.6), (0.6, 0.75), (0.75, 0.95))  # a mode in one
    # sub-band (or a model error there) does not raise the floor: the least one is noise
    excited_rel: float = 1e-3     # -30 dB: a multisine's band is flat, steps fall as 1/f^2
    # (their upper 70 % of the band lies 40 dB or more below their peak)
    min_unexcited: float = 0.25   # a quarter of a sub-band: its median is not a stray bin's
    period_blocks: int = 16       # a transient in the first blocks of a record is outvoted
    min_block: int = 256          # the median of 256-sample mean squares is within 0.2 % of
    # their mean for stationary noise
    window_factor: float = 3.0    # 3 sigma: a window of noise alone rarely passes
    max_windows: int = 12         # a report lists the strongest windows, not every one
    band_factor: float = 4.0      # 4x the white level: Welch's spread stays below it
    band_quantiles: tuple = (0.025, 0.975)   # 95 % of the excess: a stray bin does not widen it
    max_lag: int = 25             # covers the paper plant's resonance period at 5 kHz
    test_level: float = 0.01      # 99 %: the classical residual tests' level
    max_coherence: float = 0.999  # noise-free records would make the standard error zero
    min_coherence: float = 0.5    # below, H1 is mostly noise
    frf_sigmas: float = 3.0       # 3 standard errors: one bin in 370 passes by chance
    regime_bins: int = 10         # deciles: enough samples per bin for a stable mean


@dataclass(frozen=True)
class SensorOptions:
    """Outliers and dropouts of the sensor (:mod:`robrst.diagnose._sensor`).

    Attributes
    ----------
    outlier_z : float
        An outlier departs this many robust standard deviations from its neighbours.
    isolation : float
        ... and this many times its neighbours two to four samples away.
    min_run : int
        Identical readings that make a dropout.
    max_share : float
        More than this share flagged: not isolated faults, the record is left alone.
    """

    outlier_z: float = 10.0       # Gaussian noise never reaches 10 sigma in 1e9 samples
    isolation: float = 4.0        # a ringing resonance or a delay's error spreads; a spike not
    min_run: int = 5              # a quantised, noisy sensor repeats a reading 5 times rarely
    max_share: float = 0.02       # beyond 2 %, the "faults" are the signal's own behaviour


@dataclass(frozen=True)
class LevelOptions:
    """Excitation levels and the ``amplitude_dependent`` finding.

    Attributes
    ----------
    level_tol : float
        Records within this relative input RMS share a level.
    amplitude_ratio : float
        A gap ratio across levels beyond this (or below its inverse) flags amplitude
        dependence.
    floor_ratio : float
        ... when the larger gap exceeds this many noise floors.
    shape_tol : float
        Records share an excitation shape when their band shares differ by less (|log10|).
    shape_bands : int
        Bands of the input spectrum compared.
    shape_share : float
        Bands holding more than this share of the power are compared.
    hold_tol : float
        Holding fractions within this share an excitation shape.
    crest_tol : float
        Crest factors within this relative difference share an excitation shape.
    lowest_tol : float
        Training records within this relative level of the lowest are its level.
    """

    level_tol: float = 0.1        # 10 %: repeated records of one recipe differ by less
    amplitude_ratio: float = 1.5  # a linear plant gives the same relative gap at every level
    floor_ratio: float = 2.0      # a ratio of two gaps at the floor is noise
    shape_tol: float = 0.3        # a factor 2 in a band's share
    shape_bands: int = 24         # log-spaced bands: a few per octave of a typical record
    shape_share: float = 0.01     # bands without power say nothing about the shape
    hold_tol: float = 0.1         # steps hold the input; sines and multisines do not
    crest_tol: float = 0.35       # a sine's 1.4 and a multisine's 3 differ by more
    lowest_tol: float = 0.1       # as level_tol


@dataclass(frozen=True)
class LinearOptions:
    """The linear part's corrections (:mod:`robrst.diagnose.linear`).

    Attributes
    ----------
    prior_sd : dict
        Prior standard deviation per kind of correction.
    bounds : dict
        Bounds per kind of correction.
    fd_step : float
        Forward-difference step of the mode corrections.
    excited_share : float
        Input power within an octave of a mode below this share: the records do not see it.
    max_damping : float
        A corrected damping ratio is capped here.
    """

    prior_sd: dict = field(default_factory=lambda: {
        "dlog_freq": 0.1,         # a model's resonance is rarely 10 % off
        "dlog_damping": 1.0,      # damping is poorly known: a factor e
        "gain": 0.2, "input_gain": 0.2, "mode_gain": 0.2})   # gains within 20 %
    bounds: dict = field(default_factory=lambda: {
        "dlog_freq": (-0.5, 0.5),     # a factor 1.65 either way: beyond, another model
        "dlog_damping": (-3.0, 3.0),  # a factor 20 either way
        "gain": (-0.9, 2.0), "input_gain": (-0.9, 2.0), "mode_gain": (-0.9, 2.0)})  # 0.1-3x
    fd_step: float = 1e-6         # sqrt(eps)-sized: the log-ratio corrections are O(1)
    excited_share: float = 1e-5   # the low-frequency phase alone would pull the mode
    max_damping: float = 0.999    # a pair stays a pair


@dataclass(frozen=True)
class EffectOptions:
    """The effect library's data-derived grids and stability bounds
    (:mod:`robrst.diagnose._effects`).

    Attributes
    ----------
    pi_fractions : tuple of float
        Play thresholds of the Prandtl–Ishlinskii candidate, as fractions of the input's
        peak-to-peak range (log-spaced).
    knot_quantiles : tuple of float
        Knots of the static input map's hinges: quantiles of the training inputs.
    bw_step_max : float
        Bouc–Wen's ``(B + |Gamma|) |du| / 2`` at the largest per-sample step at most.
    """

    pi_fractions: tuple = (0.01, 0.02, 0.035, 0.05, 0.075, 0.1, 0.14, 0.19, 0.25, 0.33, 0.42)
    # loops from 1 % to 42 % of the range: a PI operator's weights then follow any loop shape
    knot_quantiles: tuple = (0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.65, 0.8, 0.9, 0.95, 0.98)
    # denser at the ends, where dead zones and limits sit; every knot has samples both sides
    bw_step_max: float = 0.95     # beyond it the discrete update stops contracting (diverges)


@dataclass(frozen=True)
class FitOptions:
    """The nonlinear least-squares fits and their budgets.

    Attributes
    ----------
    fit_rows : int
        Residual rows per record in a fit (every k-th sample beyond).
    nfev : int
        Evaluations of a candidate's fit during the selection.
    ftol : float
        Its relative cost tolerance.
    final_nfev : int
        An unconverged joint fit of a selected set is continued up to this many.
    level_nfev : int
        Evaluations of each per-level fit of the amplitude-dependent dynamics.
    low_level_nfev : int
        Evaluations of the linear fit on the lowest training level (amplitude finding).
    standalone_nfev : int
        Evaluations of the standalone fits (thermal dynamics, cubic stiffness).
    slope_bound : float
        Bound of a level slope per unit of level factor.
    prior_per_level : float
        Prior of a residue's level slope, relative to the residue.
    max_stiffening : float
        The cubic stiffness changes the stiffness by at most this at the largest output.
    max_delay_s : float
        Whole-sample delays are searched up to this [s] ...
    max_delay_samples : int
        ... and at most this many samples.
    refine_evals : int
        Golden-section evaluations refining a saturation limit.
    held_width : float
        A parameter whose bounds are closer than this is held, not fitted.
    """

    fit_rows: int = 8192          # the cost of a step then does not grow with the record
    nfev: int = 40                # Gauss-Newton converges in 5-20 on a well-posed candidate
    ftol: float = 1e-8            # the held-out gap changes in the 4th digit below it
    final_nfev: int = 150         # enough for a stiff Bouc-Wen + linear joint fit
    level_nfev: int = 20          # each level starts at the one below: a short walk (the
    #                               mirror's three levels: the held-out gap the same to 4
    #                               digits as with 40, the later steps walk along
    #                               corrections the records do not determine)
    low_level_nfev: int = 30      # a linear fit from the user's model
    standalone_nfev: int = 25     # three or two parameters
    slope_bound: float = 5.0      # a correction may change by 5 per unit of level factor
    prior_per_level: float = 1.0  # a residue may change by its own size per unit of level
    max_stiffening: float = 0.5   # a 50 % stiffer structure is beyond a "cubic" term
    max_delay_s: float = 5e-3     # transport and computation delays of a lab rig
    max_delay_samples: int = 200  # the search is exact per delay: bound its cost
    refine_evals: int = 8         # to 2 % of the bracket between two quantiles
    held_width: float = 1e-10     # pins are boxes of width 2e-12


@dataclass(frozen=True)
class ScreenOptions:
    """The exact linear screen's columns and grids (:mod:`robrst.diagnose._screen`).

    Attributes
    ----------
    samples : int
        Gram rows per record (every k-th sample of the whole record).
    sat_high, sat_low : tuple of float
        Quantiles of the input screened as saturation limits.
    drift_lags_s : tuple of float
        Lags of the thermal drift screened [s].
    slew_fractions : tuple of float
        Slew rates screened, as fractions of the fastest input step.
    bw_b_rel : tuple of float
        Bouc-Wen's B times the input's peak-to-peak range at the screen's points.
    bw_ratios : tuple of float
        ... and Gamma / B (its derivative is a column).
    dz_widths : tuple of float
        Dead-zone half widths screened, as fractions of the input's range.
    batch : int
        Input-side columns simulated together.
    ridge : float
        Relative ridge on the (normalised) effect columns.
    cut_samples : int
        Records from rest are screened and fitted on this many samples (the thermal
        candidates on whole records).
    """

    samples: int = 100_000        # the Gram's statistics settle long before
    sat_high: tuple = (0.8, 0.9, 0.95, 0.98, 0.995)   # limits met by 20 % ... 0.5 % of samples
    sat_low: tuple = (0.005, 0.02, 0.05, 0.1, 0.2)
    drift_lags_s: tuple = (0.3, 1.0, 3.0, 10.0, 30.0, 100.0)   # half-decades of lag
    slew_fractions: tuple = (0.3, 0.1, 0.03, 0.01)   # half-decades below the fastest step
    bw_b_rel: tuple = (0.3, 1.0, 3.0)   # narrow, medium and wide loops
    bw_ratios: tuple = (1.0,)     # Gamma = B: the usual symmetric loop
    dz_widths: tuple = (0.01, 0.03, 0.06)   # dead zones of 1-6 % of the range
    batch: int = 16               # simulated together: one BLAS call per batch
    ridge: float = 1e-9           # collinear columns stay solvable
    cut_samples: int = 100_000    # 20 s at 5 kHz: every candidate shows by then


@dataclass(frozen=True)
class SelectOptions:
    """The forward selection, credit by removal and ties (:mod:`robrst.diagnose._select`).

    Attributes
    ----------
    min_shrink : float
        An explanation must remove this share of the excess gap it faces ...
    margin : float
        ... and beat the alternative by this factor in held-out gap.
    max_effects : int
        Effects selected at most.
    refine_top : int
        Candidates fitted per step (the best by the screen) ...
    screen_spread : float
        ... when their screened gap is within this factor of the best.
    promising : float
        A screen must improve on the current set by this factor.
    short_of_screen : float
        A fit this far above its screen (training) is fitted again from fresh starts.
    near_floor : float
        A hysteresis form this close to the floor needs no other form.
    second_point : bool
        Screen about the linear re-fit too (not only the user's model).
    second_point_min : float
        ... when a re-fitted correction moves by more than this.
    """

    min_shrink: float = 0.3       # a third of the excess: more than noise moves a gap
    margin: float = 1.1           # 10 %: a held-out gap's own spread between fits
    max_effects: int = 3          # more effects than this overfit the records we see
    refine_top: int = 3           # the screen's order is first order: try the next two
    screen_spread: float = 2.0    # a screen twice the best rarely wins its fit
    promising: float = 0.97       # 3 %: below, the screen's first-order error dominates
    short_of_screen: float = 1.5  # the joint fit is stuck in the smaller set's minimum
    near_floor: float = 2.0       # the other form could not do much better
    second_point: bool = False    # the user's model is the better point on every suite case
    second_point_min: float = 1e-3   # the re-fit did not move: the same point


@dataclass(frozen=True)
class VerdictOptions:
    """The verdict's bars and the findings (:mod:`robrst.diagnose._verdict`).

    Attributes
    ----------
    none_ratio : float
        A held-out gap within this many noise floors: nothing to explain.
    resolved_gap : float
        ... or below this NRMSE (noise-free records, a floor of rounding).
    near_ratio : float
        An answer must leave at most this many noise floors ...
    near_excess : float
        ... or this share of the excess gap.
    held_out_min : float
        A candidate removing under this share of the held-out gap (but much of the
        training gap) fits the training records only.
    offset_share : float
        A constant this share of the held-out residual: finding ``output_offset`` ...
    gain_share : float
        ... unless a gain explains this much more of it ...
    offset_agree : float
        ... or the training residual's constant differs by more than this (relative).
    unmodelled_share : float
        A higher linear order must remove this share of the excess the re-fit leaves.
    unmodelled_orders : tuple of int
        Orders added to the re-fit's for the ``unmodelled_dynamics`` finding.
    unmodelled_same_order : float
        The re-fit's own order fitted from the data alone is the finding's model when its
        held-out gap is within this factor of the best higher order's (the model's
        dynamics are wrong, not short of an order).
    unmodelled_iterations : int
        Vector-fitting iterations of those fits.
    unmodelled_band : float
        The finding's band: where the models differ by this share of their largest
        difference.
    unmodelled_pole_tol : float
        A pole this far (relative) from every re-fitted pole is an extra mode.
    """

    none_ratio: float = 1.25      # noise-floor estimates scatter by ~10-20 %
    resolved_gap: float = 1e-6    # six digits: the records' own rounding
    near_ratio: float = 2.0       # twice the floor: little left for another cause
    near_excess: float = 0.35     # the margin over an effect outside the library
    held_out_min: float = 0.05    # 5 %: within the held-out gap's spread
    offset_share: float = 0.5     # most of the residual: a constant dominates it
    gain_share: float = 0.1       # a gain change moves a unipolar output's mean: it explains
    # the rest (a sensor zero leaves nothing to a gain)
    offset_agree: float = 0.25    # a sensor zero is the same in every record
    unmodelled_share: float = 0.5   # half the excess: more than a re-fit's noise
    unmodelled_orders: tuple = (2, 4)   # one or two missing pairs
    unmodelled_same_order: float = 1.1  # the model's order from the data within 10 % of them
    unmodelled_iterations: int = 8      # vector fitting converges in a few
    unmodelled_band: float = 0.2  # a fifth: where the data see the missing dynamics
    unmodelled_pole_tol: float = 0.05   # 5 %: a re-fitted pole moves less


@dataclass(frozen=True)
class DiagnoseOptions:
    """Every tuning constant of the diagnosis, by stage.

    Attributes
    ----------
    records : RecordOptions
    noise : NoiseOptions
    sensor : SensorOptions
    levels : LevelOptions
    linear : LinearOptions
    effects : EffectOptions
    fit : FitOptions
    screen : ScreenOptions
    select : SelectOptions
    verdict : VerdictOptions
    """

    records: RecordOptions = field(default_factory=RecordOptions)
    noise: NoiseOptions = field(default_factory=NoiseOptions)
    sensor: SensorOptions = field(default_factory=SensorOptions)
    levels: LevelOptions = field(default_factory=LevelOptions)
    linear: LinearOptions = field(default_factory=LinearOptions)
    effects: EffectOptions = field(default_factory=EffectOptions)
    fit: FitOptions = field(default_factory=FitOptions)
    screen: ScreenOptions = field(default_factory=ScreenOptions)
    select: SelectOptions = field(default_factory=SelectOptions)
    verdict: VerdictOptions = field(default_factory=VerdictOptions)


OPTIONS = DiagnoseOptions()
