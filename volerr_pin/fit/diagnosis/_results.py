"""What a diagnosis finds, typed: candidates, their scores, the changes accepted, the rounds and
the result with its JSON report (docs/reports.md); and the BLAS threads its work runs on."""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np

from ..identify import Observations
from ...model import Machine

__all__ = ["EVIDENCE_BIC", "PRACTICAL_AMPLITUDE", "PRACTICAL_GAIN", "SIGNIFICANCE", "STATED_NOISE_FACTOR", "Alternative",
           "Candidate", "Change", "Diagnosis", "DriftSeries", "Evidence", "Raise", "Role", "Score", "Separation", "Step", "ThermalModel",
           "one_blas_thread"]


@contextmanager
def one_blas_thread():
    """Limit BLAS and OpenMP (threadpoolctl) and numba to one thread inside the block: on a
    diagnosis's matrices of a few hundred columns, threads cost more in waiting than they give
    (and beside another busy process they can double the time). Without threadpoolctl BLAS keeps
    its threads.

    Yields
    ------
    None
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - a declared dependency
        yield
        return
    import numba

    threads = numba.get_num_threads()
    numba.set_num_threads(1)  # the compiled kinematics' own pool
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        numba.set_num_threads(threads)


#: |value| / standard uncertainty of an accepted effect's size
SIGNIFICANCE = 3.0
#: two models whose BIC differ by less than this are not told apart by the data (Kass and
#: Raftery, 1995, J. Am. Stat. Assoc. 90(430): a difference above 10 is "very strong"
#: evidence, below it the evidence is at best "strong" and may be chance)
EVIDENCE_BIC = 10.0
#: an effect found is of practical significance when its held-out RMS gain is at least this
#: share of the held-out RMS before it ...
PRACTICAL_GAIN = 0.02
#: ... and its amplitude at the tool (half its range over the measured points, in the direction
#: it moves most) is at least this share of the noise per component
PRACTICAL_AMPLITUDE = 0.5
#: a noise floor that is only an upper bound from the residual is said to be reached only when it
#: is within this factor of the noise the instrument states (``sigma_um`` per component)
STATED_NOISE_FACTOR = 2.0


class Role(StrEnum):
    """What a candidate or an accepted change is to the model (a string in reports).

    ``EFFECT``: a catalogue effect (:mod:`~volerr_pin.fit.diagnosis`); ``MISSING``: a
    geometric component the spec leaves out; ``RAISE``: a candidate that makes an existing
    component richer; ``UNDER_MODELLED``: such a raise, accepted.
    """

    EFFECT = "effect"
    MISSING = "missing"
    RAISE = "raise"
    UNDER_MODELLED = "under_modelled"


@dataclass
class Candidate:
    """One thing the model could be missing: where it goes and how it reads.

    Attributes
    ----------
    name : str
        Catalogue name ("backlash", "thermal_drift", "straightness", ...).
    axis : str or None
        The axis (or body) it sits on.
    direction : str or None
        "x", "y", "z" (rotations: about that axis).
    component : str
        The component error it is modelled as ("EXX", "EC0Y").
    table : dict or None
        An effect's term as its kind offers it: a table in the spec file's form, zero-valued,
        read into a term where it is scored; None for the model's own geometry (offered as
        ``term``).
    driver : str, optional
        The covariate that drives it ("t", "T_spindle", "Fx", "dir_X", "q_X").
    label : str
        What it is, in words (:meth:`describe`).
    kind : Role, default Role.EFFECT
        A catalogue effect, a geometric component the spec leaves out (``MISSING``) or an
        existing component with ``by`` degrees more / twice the nodes (``RAISE``).
    change : tuple of str (2,), optional
        Raises: the component's form before and after ("degree 2", "degree 3").
    by : int, default 1
        Raises: degrees gained.
    term : TermSpec or None
        The model's own geometry (a missing component, a raise): its term, zero-valued.
    start : ndarray or None
        A raise: the richer term's coefficients that reproduce the component's present
        function, where its refit starts.
    """

    name: str                 # catalogue name
    axis: str | None
    direction: str | None     # "x", "y", "z" (rotations: about that axis)
    component: str
    table: dict | None        # an effect's term table (zero-valued), as its kind offers it
    driver: str | None = None  # covariate that drives it ("t", "T_spindle", "Fx", "dir_X", "q_X")
    label: str = ""
    kind: Role = Role.EFFECT
    change: tuple[str, str] | None = None
    by: int = 1
    term: object = None       # TermSpec of the model's own geometry (missing, raised), zero-valued
    start: object = None      # a raise's coefficients reproducing the present function

    def describe(self) -> str:
        """The candidate in words, e.g. "backlash on X in x driven by dir_X (EXX)" (an effect
        kind may say it otherwise: :meth:`~volerr_pin.fit.diagnosis.EffectKind.describe`).

        Returns
        -------
        str
            The label.
        """
        if self.kind == Role.RAISE:
            return f"geometric component {self.component} under-modelled ({self.change[0]} -> {self.change[1]})"
        where = f" on {self.axis}" if self.axis else ""
        d = f" in {self.direction}" if self.direction else ""
        by = f" driven by {self.driver}" if self.driver else ""
        return f"{self.name}{where}{d}{by} ({self.component})"


@dataclass
class Score:
    """How well one candidate explains the residual of a round.

    Attributes
    ----------
    label : str
        The candidate's label.
    extra : int
        Independent columns it adds to the base model (0: nothing new).
    p_value : float
        F-test p-value, Bonferroni-corrected for periods searched in a periodogram.
    bic_gain : float
        Decrease of the Bayesian information criterion.
    cv_rms_um : float or None
        k-fold cross-validated RMS with the candidate [um]; None where not computed.
    rss_drop : float
        Fraction of the base residual sum of squares it removes.
    candidate : Candidate or None
        The candidate.
    term : TermSpec or None
        Its term; None when it adds nothing.
    coefficients : ndarray, shape (term.size,), or None
        Its fitted coefficients (SI).
    columns : ndarray, shape (rows, extra), or None
        Its weighted design columns.
    note : str
        Why a candidate that passed the round's tests was not accepted: a per-revolution error
        that does not repeat from one turn to the next (with its per-turn coefficients) or whose
        period left its window in the joint refit; a joint refit whose values no spec could
        hold; or a size in the joint refit below :data:`SIGNIFICANCE`. Empty otherwise.
    """

    label: str
    extra: int
    p_value: float
    bic_gain: float
    cv_rms_um: float | None
    rss_drop: float
    candidate: Candidate | None = field(default=None, repr=False)
    term: object = field(default=None, repr=False)
    coefficients: np.ndarray | None = field(default=None, repr=False)
    columns: np.ndarray | None = field(default=None, repr=False)
    note: str = ""

    def summary(self) -> "Score":
        """The score without its term and design columns (what a :class:`Step` keeps: the
        columns are rows x extra numbers for every candidate of every round).

        Returns
        -------
        Score
            A copy without ``term``, ``coefficients`` and ``columns``.
        """
        return replace(self, term=None, coefficients=None, columns=None)

    def to_dict(self) -> dict:
        """The score in a report.

        Returns
        -------
        dict
            ``label``, ``extra``, ``p_value``, ``bic_gain``, ``cv_rms_um``, ``rss_drop``, and
            ``note`` when set.
        """
        out = {"label": self.label, "extra": self.extra, "p_value": self.p_value, "bic_gain": self.bic_gain,
               "cv_rms_um": self.cv_rms_um, "rss_drop": self.rss_drop}
        if self.note:
            out["note"] = self.note
        return out


@dataclass
class Change:
    """A change the diagnosis made to the model: an effect (or a missing geometric
    component) added, or an existing component raised.

    Attributes
    ----------
    kind : Role
        ``EFFECT`` (an effect or a missing component added) or ``UNDER_MODELLED``.
    label, name, component : str
        What was found, the catalogue name and the component error it is modelled as.
    axis, direction, driver : str or None
        Where it sits (None when the same at the tool through several axes), the tool
        direction it moves, and the covariate that drives it.
    p_value, bic_gain : float
        Its score in the round it was accepted in.
    same_at_tool_as : list of str
        Other components it cannot be told apart from at the tool.
    step : int
        The round (from 0) it was accepted in.
    names : list of str
        The coefficients it added (a raised component: all of the component's).
    by : int
        Raises: degrees (or node doublings) gained.
    form_before, form_after : str or None
        Raises: the component's form before and after ("degree 2", "table of 9 nodes").
    rms_before_um, max_before_um, rms_after_um, max_after_um : float or None
        Held-out RMS and largest residual before and after it [um].
    significance : float or None
        Its size in standard uncertainties in the refit.
    parameters : dict
        Effects: coefficient -> {"value", "uncertainty", "unit"} after the final fit.
    note : str
        Dropped effects and those below practical significance: why.
    amplitude_um : float or None
        Half the range of its effect at the tool over the measured points, in the direction
        it moves most [um].
    gain_um : float or None
        Held-out RMS before minus after it [um].
    members : list of str
        A finding grouped from several accepted terms (multi-sensor thermal drift): their labels.
    kept_jointly : str
        Why an effect below significance alone stays (collinear terms share what they explain);
        empty otherwise.
    details : ThermalModel, Separation, Alternative or None
        What its kind reports besides: a thermal drift's model over time, the measurement that
        would separate a possible per-revolution error from the axis' geometry, or the rival
        reading a possible finding cannot be told apart from.
    """

    kind: Role
    label: str
    name: str
    component: str
    axis: str | None
    direction: str | None
    driver: str | None
    p_value: float
    bic_gain: float
    same_at_tool_as: list[str] = field(default_factory=list)
    step: int = 0
    names: list[str] = field(default_factory=list)
    by: int = 0
    form_before: str | None = None
    form_after: str | None = None
    rms_before_um: float | None = None
    max_before_um: float | None = None
    rms_after_um: float | None = None
    max_after_um: float | None = None
    significance: float | None = None
    parameters: dict = field(default_factory=dict)
    note: str = ""
    amplitude_um: float | None = None
    gain_um: float | None = None
    members: list[str] = field(default_factory=list)
    kept_jointly: str = ""
    details: "ThermalModel | Separation | Alternative | None" = None

    def to_dict(self) -> dict:
        """The change in the report (docs/reports.md).

        Returns
        -------
        dict
            ``label``, ``name``, ``component``, ``same_at_tool_as``, ``direction``, ``driver``,
            ``p_value``, ``bic_gain``, ``kind``, ``axis``, ``rms_before_um`` ... as documented.
        """
        out = {"label": self.label, "name": self.name, "component": self.component,
               "same_at_tool_as": list(self.same_at_tool_as), "direction": self.direction, "driver": self.driver,
               "p_value": self.p_value, "bic_gain": self.bic_gain, "kind": self.kind, "axis": self.axis}
        if self.kind == Role.UNDER_MODELLED:
            out.update({"from": self.form_before, "to": self.form_after})
        out.update(rms_before_um=self.rms_before_um, max_before_um=self.max_before_um)
        if self.significance is not None:
            out["significance"] = self.significance
        out.update(rms_after_um=self.rms_after_um, max_after_um=self.max_after_um)
        if self.kind == Role.EFFECT:
            out.update(amplitude_um=self.amplitude_um, gain_um=self.gain_um)
        if self.kind == Role.EFFECT and (self.parameters or not self.note):  # a dropped effect has no final values
            out["parameters"] = self.parameters
        if self.members:
            out["members"] = list(self.members)
        if self.kept_jointly:
            out["kept_jointly"] = self.kept_jointly
        if self.details is not None:
            out.update(self.details.to_dict())
        if self.note:
            out["note"] = self.note
        return out


@dataclass
class ThermalModel:
    """A thermal drift finding's model over time (the details of a
    :attr:`~volerr_pin.fit.diagnosis.EffectKind.over_time` kind).

    Attributes
    ----------
    sensors : list of str
        The temperature sensors it is driven by (empty: time alone).
    drivers : list of str
        Its terms' drivers, in the order they were accepted.
    selection : str
        How the sensors were chosen, round by round.
    lag_s : float
        The common lag of its temperature terms [s] (0: none kept).
    lags_tried : list of dict
        Each lag tried (``lag_s``) and the held-out RMS with it (``rms_holdout_um``).
    time_check : dict or None
        The final model fitted on the first part of the run, predicting the rest, with and
        without the drift (docs/reports.md); None when the first part alone does not determine it.
    """

    sensors: list[str]
    drivers: list
    selection: str
    lag_s: float = 0.0
    lags_tried: list[dict] = field(default_factory=list)
    time_check: dict | None = None

    def to_dict(self) -> dict:
        """Its fields in the finding's report (docs/reports.md).

        Returns
        -------
        dict
        """
        return {"sensors": list(self.sensors), "drivers": list(self.drivers), "selection": self.selection,
                "lag_s": self.lag_s, "lags_tried": list(self.lags_tried), "time_check": self.time_check}

    def lines(self) -> list[str]:
        """What the text report says under the finding.

        Returns
        -------
        list of str
        """
        out = []
        if self.sensors:
            lags = ", ".join(f"{x['lag_s']:g} s: {x['rms_holdout_um']:.3f}" for x in self.lags_tried)
            tried = f" (held-out RMS by lag: {lags} um)" if lags else " (no lag tried)"
            out.append(f"  sensors {', '.join(self.sensors)}; lag {self.lag_s:g} s{tried}")
        else:
            out.append("  driven by time alone (no temperature sensor chosen)")
        out.append(f"  chosen by {self.selection}")
        check = self.time_check
        if check:
            out.append(f"  check over time: fitted on the first {check['fit_share']:.0%} of the run "
                       f"({check['fit_points']} points), predicts the other {check['predicted_points']} "
                       f"with RMS {check['rms_predicted_um']:.3f} um (without the drift "
                       f"{check['rms_predicted_without_um']:.3f} um)")
        return out


@dataclass
class Separation:
    """A possible per-revolution error the data cannot tell from the axis' own geometry, and
    the measurement that would (the details of a
    :attr:`~volerr_pin.fit.diagnosis.EffectKind.per_revolution` kind left undecided).

    Attributes
    ----------
    amplitude_arcsec : float or None
        The candidate's amplitude in its last round [arcsec].
    separate_by : dict
        The measurement, as :func:`volerr_pin.studies.plan.plan` plans it: ``instrument``,
        ``budget``, ``zone`` (the other axes held, mm / deg) and ``terms``.
    """

    amplitude_arcsec: float | None
    separate_by: dict

    def to_dict(self) -> dict:
        """Its fields in the report (docs/reports.md).

        Returns
        -------
        dict
        """
        return {"amplitude_arcsec": self.amplitude_arcsec, "separate_by": self.separate_by}


@dataclass
class Alternative:
    """A named finding the data cannot tell apart from raising its axis' own components: two
    readings that explain the measurements within :data:`EVIDENCE_BIC` (the details of a
    possible finding that has a rival reading).

    Attributes
    ----------
    readings : list of str
        The two readings: the named effect's label, then the raises' (joined by " and ").
    in_model : str
        The reading the final model holds: ``"named"`` or ``"raise"``.
    bic_difference : float
        BIC of the model with the raise minus BIC of the model with the named effect, each
        refitted on every observation (positive: the named reading is the better explanation).
    separate_at : dict
        Where the two fitted readings differ most at the tool within the travel: ``positions``
        (axis -> mm / deg), ``difference_um`` (the distance between their tool-point errors
        there [um]), and ``advice`` (in words: the pose, and what else would separate them).
    """

    readings: list
    in_model: str
    bic_difference: float
    separate_at: dict

    def to_dict(self) -> dict:
        """Its fields in the report (docs/reports.md).

        Returns
        -------
        dict
        """
        return {"readings": list(self.readings), "in_model": self.in_model, "bic_difference": self.bic_difference,
                "separate_at": self.separate_at}


@dataclass
class Raise:
    """An existing geometric component the diagnosis raised, from the spec's form to the final one.

    Attributes
    ----------
    label, name, component : str
        The raise in words, its catalogue name and the component.
    axis, direction : str or None
        Where it sits and the direction it moves.
    form_before, form_after : str
        The spec's form and the final one ("degree 2" -> "degree 4", "table of 5 nodes").
    rounds : list of int
        The rounds (from 1) it was raised in.
    rms_before_um, rms_after_um : float or None
        Held-out RMS before the first raise and after the last [um].
    p_value : float
        The smallest p-value of its raises.
    """

    label: str
    name: str
    component: str
    axis: str | None
    direction: str | None
    form_before: str
    form_after: str
    rounds: list[int]
    rms_before_um: float | None
    rms_after_um: float | None
    p_value: float

    def to_dict(self) -> dict:
        """The raise in the report (docs/reports.md).

        Returns
        -------
        dict
            ``label``, ``name``, ``component``, ``axis``, ``direction``, ``from``, ``to``,
            ``rounds``, ``rms_before_um``, ``rms_after_um``, ``p_value``.
        """
        return {"label": self.label, "name": self.name, "component": self.component, "axis": self.axis,
                "direction": self.direction, "from": self.form_before, "to": self.form_after,
                "rounds": list(self.rounds), "rms_before_um": self.rms_before_um,
                "rms_after_um": self.rms_after_um, "p_value": self.p_value}


@dataclass
class Step:
    """One round: the scores of every candidate, best first, and what was accepted, if anything.

    Attributes
    ----------
    number : int
        The round, from 0.
    rms_holdout_um : float
        Held-out RMS of the model at the start of the round [um].
    candidates : list of Score
        Every candidate's score, best (largest BIC gain) first.
    residual : ndarray, shape (rows,)
        Residual of every observation row before this round's change [m or rad].
    machine : Machine or None
        The model after the round (only with ``keep_machines``).
    accepted_all : list of Change
        What was accepted: more than one when several under-modelled components were raised
        together; empty when nothing was.
    """

    number: int
    rms_holdout_um: float
    candidates: list[Score]
    residual: np.ndarray = field(repr=False)
    machine: Machine | None = field(default=None, repr=False)
    accepted_all: list[Change] = field(default_factory=list)

    @property
    def accepted(self) -> Change | None:
        """The first change accepted in the round (Change), or None."""
        return self.accepted_all[0] if self.accepted_all else None


@dataclass
class Diagnosis:
    """Result of :func:`~volerr_pin.fit.diagnosis.diagnose`; :meth:`to_dict` gives the JSON report.

    Attributes
    ----------
    machine : Machine
        The final model.
    base : Machine
        The base model as fitted before the first round.
    effects : list of Change
        The physical effects (and missing geometric components) found, in order.
    steps : list of Step
        Every round.
    rms_before_um, rms_after_um : float
        Held-out RMS of the base and the final model [um].
    rms_fit_um : float
        RMS of the final model's residual at the fitted points [um].
    noise_floor_um : float
        The noise floor [um] (see ``noise_floor_source``).
    noise_floor_source : str
        Where it comes from: repeated points, or an upper bound from the final residual.
    reaches_noise_floor : bool or None
        Whether the final held-out RMS is within 1.2 times the floor; None when that cannot be
        told: the floor is only an upper bound from the final residual and no noise was stated.
    alpha : float
        Family-wise significance level of each round.
    seconds : float
        Time taken [s].
    observations : Observations
        The observations diagnosed.
    residual_analysis : dict
        The base residual against positions and covariates (see
        :func:`~volerr_pin.fit.diagnosis.residual_analysis`).
    under_modelled : list of Raise
        Existing components whose degree or table density was raised.
    dropped : list of Change
        Effects accepted in a round whose size was no longer significant at the end.
    noise_floor_upper_bound : bool
        Whether the floor is only an upper bound.
    possible : list of Change
        Effects that passed the statistical tests but are below practical significance
        (:data:`PRACTICAL_GAIN`, :data:`PRACTICAL_AMPLITUDE`); not in the final model.
    noise_stated_um : float
        The noise the observations state (``sigma_um`` per position component, as the RMS of
        the 3D norm) [um]; NaN when none was stated.
    residual : ndarray, shape (rows,) or None
        The final model's residual of every observation row [m or rad].
    stopped : dict
        Why the rounds ended: ``reason`` ("nothing_passes", or "round_limit" when the round
        after the last one allowed to accept, which only scores, had candidates still passing
        the F-test and the cross-validation), ``rounds`` (run), ``max_rounds``,
        ``still_passing`` (their labels, best first) and ``label`` (in words).
    """

    machine: Machine
    base: Machine
    effects: list[Change]
    steps: list[Step]
    rms_before_um: float
    rms_after_um: float
    rms_fit_um: float
    noise_floor_um: float
    noise_floor_source: str
    reaches_noise_floor: bool | None
    alpha: float
    seconds: float
    observations: Observations = field(repr=False)
    residual_analysis: dict = field(default_factory=dict)
    under_modelled: list[Raise] = field(default_factory=list)
    dropped: list[Change] = field(default_factory=list)
    noise_floor_upper_bound: bool = False
    possible: list[Change] = field(default_factory=list)
    noise_stated_um: float = math.nan
    residual: np.ndarray | None = field(default=None, repr=False)
    stopped: dict = field(default_factory=dict)

    def off_spec(self) -> dict:
        """The raised components grouped: one finding "geometry off the spec on n components".

        Returns
        -------
        dict
            ``count``, ``components`` (names) and ``label``.
        """
        comps = [u.component for u in self.under_modelled]
        label = (f"geometry off the spec on {len(comps)} component{'s' if len(comps) != 1 else ''}"
                 if comps else "geometry within the spec's function space")
        return {"count": len(comps), "components": comps, "label": label}

    def to_dict(self) -> dict:
        """The JSON report (docs/reports.md).

        Returns
        -------
        dict
            ``machine``, ``rms_before_um``, ``rms_after_um``, ``noise_floor_um``, ``effects``,
            ``under_modelled``, ``dropped``, ``steps`` (the first ten candidates of each),
            ``test``, ``residual_analysis``, ``seconds`` and more (docs/reports.md).
        """
        return {
            "machine": self.machine.name,
            "rms_before_um": self.rms_before_um,
            "rms_after_um": self.rms_after_um,
            "rms_fit_um": self.rms_fit_um,
            "noise_floor_um": self.noise_floor_um,
            "noise_floor_source": self.noise_floor_source,
            "noise_floor_upper_bound": self.noise_floor_upper_bound,
            "reaches_noise_floor": self.reaches_noise_floor,
            "noise_stated_um": self.noise_stated_um,
            "effects": [e.to_dict() for e in self.effects],
            "possible": [e.to_dict() for e in self.possible],
            "practical_significance": {"gain_share": PRACTICAL_GAIN, "amplitude_noise_share": PRACTICAL_AMPLITUDE,
                                       "rule": f"an effect is found when its held-out RMS gain is at least "
                                               f"{PRACTICAL_GAIN:.0%} of the held-out RMS before it and its "
                                               f"amplitude at least {PRACTICAL_AMPLITUDE:g} of the noise per "
                                               "component; else it is possible, below practical significance"},
            "off_spec": self.off_spec(),
            "under_modelled": [u.to_dict() for u in self.under_modelled],
            "dropped": [e.to_dict() for e in self.dropped],
            "stopped": dict(self.stopped),
            "steps": [{"step": s.number, "rms_holdout_um": s.rms_holdout_um,
                       "accepted": [a.label for a in s.accepted_all] or None,
                       "candidates": [c.to_dict() for k, c in enumerate(s.candidates) if k < 10 or c.note]}
                      for s in self.steps],
            "test": f"F-test at alpha = {self.alpha:g} / number of candidates (Bonferroni; periods "
                    "searched in a periodogram also / number of periods), a lower k-fold "
                    f"cross-validated RMS, and |value| >= {SIGNIFICANCE:g} standard uncertainties "
                    "after the refit; candidates ranked by BIC",
            "residual_analysis": self.residual_analysis,
            "seconds": self.seconds,
        }


@dataclass
class Evidence:
    """What a change did, for pictures: the residual along one error direction against the
    change's driver, before and after it.

    Attributes
    ----------
    x : ndarray, shape (rows,)
        The driver at each row's point.
    x_label : str
        The driver with its unit.
    before_um, after_um : ndarray, shape (rows,)
        The residual before and after the change [um].
    direction : str
        The error direction ("x", "y", "z").
    label : str
        The change in words.
    """

    x: np.ndarray
    x_label: str
    before_um: np.ndarray
    after_um: np.ndarray
    direction: str
    label: str


@dataclass
class DriftSeries:
    """A thermal drift over the run, for pictures: what was measured in its direction against
    what the final model says, and the sensors it reads.

    Attributes
    ----------
    label : str
        The finding in words.
    direction : str
        "x", "y" or "z".
    t_h : ndarray, shape (rows,)
        Time of each observation row in its direction [h], sorted.
    measured_um : ndarray, shape (rows,)
        The drift measured: the final residual plus the model's drift [um].
    model_um : ndarray, shape (rows,)
        The model's drift [um].
    contributions_um : dict of str to ndarray (rows,)
        Each driver's share of the model's drift (``T_<sensor>``, ``t``) [um].
    temperatures : dict of str to ndarray (rows,)
        The chosen sensors' temperatures [degC].
    fit_until_h : float or None
        The end of the part of the run the check over time fitted on [h].
    """

    label: str
    direction: str
    t_h: np.ndarray
    measured_um: np.ndarray
    model_um: np.ndarray
    contributions_um: dict
    temperatures: dict
    fit_until_h: float | None = None
