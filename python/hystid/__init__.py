"""hystid from Python: friction joints in vibrating structures, simulated,
tested, identified and diagnosed by the hystid library.

Every function calls the library as the ``hystid`` command does and returns
what the command writes, as plain dicts with the same field names (and the
same numbers) as its JSON files, and signals as numpy arrays:

==================  ==========================================  =================
function            returns                                     the command's
==================  ==========================================  =================
``model``           a :class:`Model`                            test definition
``simulate``        the response (numpy)                        (library only)
``virtual_test``    recording arrays, ``recording`` (sidecar),  ``simulate``
                    ``frf``, ``summary``
``extract``         nonlinear FRFs                              ``frf.json``
``identify``        the fit                                     ``fit.json``
``diagnose``        the diagnosis                               ``diagnosis.json``
``validate``        the validation (+ the simulated response)   ``validate.json``
``fit_coil``        the shaker's coil (R, L, Bl)                ``fit.json``'s
                                                                ``coil``
==================  ==========================================  =================

Errors are :class:`HystidError` (a ``ValueError``) carrying the message the
command line prints. The GIL is released while the library works, so other
Python threads run meanwhile.
"""

import json
import os
import pathlib

import numpy as np

from . import _hystid
from ._hystid import DEFAULT_TEST, HystidError, Model

__version__ = _hystid.VERSION

__all__ = [
    "DEFAULT_TEST",
    "HystidError",
    "Model",
    "Simulation",
    "diagnose",
    "diagnose_time",
    "extract",
    "fit_coil",
    "frf_arrays",
    "identify",
    "identify_points",
    "identify_time",
    "model",
    "parameters_table",
    "simulate",
    "validate",
    "virtual_test",
]

OUTPUTS = ("displacement", "velocity", "acceleration", "element_force")

#: The calls that can take long (:func:`simulate`, :func:`virtual_test`,
#: :func:`extract`, :func:`identify`, :func:`identify_time`,
#: :func:`diagnose`, :func:`diagnose_time`, :func:`validate`) take ``progress``: a callable given
#: one dict per event, as the command's progress line draws them:
#: ``{"stage": "dwell", "level_index", "frequency_hz"}`` from the test bench,
#: ``{"stage": "fit", "evaluation", "cost"}`` from a fit,
#: ``{"stage": "diagnosis", "event": "baseline" | "round" | "candidate" |
#: "checking", ...}`` from a diagnosis, and ``{"stage": "progress", "task",
#: "done", "total"}`` from a simulation (``task`` ``"simulating"``, every
#: 262 144 samples), a reduction (``"reducing"``: a stepped sine's dwells, a
#: swept sine's whole reductions) and a validation's FRF comparison. It is
#: called with the GIL held, from the library's worker threads too. Ctrl-C
#: (with or without a callable) and an exception the callable raises stop
#: the work at the next dwell, evaluation, candidate or progress event, and
#: the call raises it; the callable is not called again after it raised.
PROGRESS = "progress"


def _definition_text(definition):
    """A test definition (TOML text, JSON text, a dict, or a ``pathlib.Path``
    to a TOML file) as TOML text, with the name errors give it."""
    if isinstance(definition, os.PathLike):
        with open(definition, encoding="utf-8") as f:
            return f.read(), os.fspath(definition)
    if isinstance(definition, dict):
        return _hystid.json_to_toml(json.dumps(definition)), "test definition"
    if isinstance(definition, str):
        if definition.lstrip().startswith("{"):
            return _hystid.json_to_toml(definition), "test definition"
        if _names_a_toml_file(definition):
            return _definition_text(pathlib.Path(definition))
        return definition, "test definition"
    raise TypeError(
        "a test definition is TOML text, a dict, JSON text or a path, "
        f"not {type(definition).__name__}"
    )


def _names_a_toml_file(text):
    """A string the command line would take as a file: one line ending in
    ``.toml`` (TOML text always holds a ``=`` or a table on its lines)."""
    t = text.strip()
    return "\n" not in t and t.endswith(".toml") and "=" not in t


def _names(names):
    """Effect names as the command line takes them: a list, or one string
    of comma-separated names (``"all"``, ``"default,clearance"``)."""
    if names is None:
        return None
    if isinstance(names, str):
        return [n.strip() for n in names.split(",") if n.strip()]
    return list(names)


def _band(band):
    """A band as ``(lo, hi)`` or as the command line writes it, ``"lo:hi"``."""
    if band is None:
        return None
    return list(_hystid.range_option(band, "band_hz", "Hz"))


def model(source):
    """A structural model.

    ``source`` is a test definition (TOML text, a ``pathlib.Path`` to a
    TOML file, or the same as a dict; ``[test]`` may be left out), a model in its JSON
    form (fit.json's ``model``: a dict with ``linear`` and ``elements``, or
    its JSON text), or a :class:`Model` (returned as is).

    >>> m = model({"system": {"mass": 10.0, "damping": 200.0, "stiffness": 1e7},
    ...            "joint": {"kind": "jenkins", "kd": 2.4e7, "fd": 246.048}})
    """
    if isinstance(source, Model):
        return source
    if isinstance(source, dict) and "linear" in source:
        return Model.from_json(json.dumps(source))
    if isinstance(source, str) and source.lstrip().startswith("{"):
        parsed = json.loads(source)
        if isinstance(parsed, dict) and "linear" in parsed:
            return Model.from_json(source)
    text, origin = _definition_text(source)
    return Model.from_toml(text, origin)


_as_model = model


def _f64(x, name):
    """A contiguous float64 view of ``x`` (no copy when it already is one)."""
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.ndim != 1:
        raise HystidError(f"{name}: expected a 1-D array, got shape {a.shape}")
    return a


def simulate(model, force, sample_rate_hz, output="displacement", progress=None):
    """The response of ``model`` (a :class:`Model` or anything :func:`model`
    takes) driven from rest by ``force`` (N) sampled at ``sample_rate_hz``.

    ``output``: ``"displacement"`` (m), ``"velocity"``, ``"acceleration"``,
    ``"element_force"`` (the elements' total force, N), or ``"all"`` for a
    dict of the four. A contiguous float64 ``force`` is read in place; the
    result is a new float64 array, one sample per force sample.
    ``progress``: see :data:`PROGRESS` (``"simulating"``, samples done of
    all).
    """
    m = _as_model(model)
    f = _f64(force, "force")
    if output == "all":
        return dict(zip(OUTPUTS, _hystid.simulate_all(m, f, float(sample_rate_hz), progress)))
    return _hystid.simulate(m, f, float(sample_rate_hz), output, progress)


class Simulation:
    """A simulation of ``model`` at ``sample_rate_hz`` that carries its state
    from one :meth:`run` to the next: a force fed in blocks (from a data
    acquisition, a co-simulation, a file read in pieces) gives, block by
    block, the samples :func:`simulate` gives on the whole, to the bit.

    A run that stops inside its block (Ctrl-C, the ``progress`` callable's
    exception, a solve that fails) leaves the state part-way through it:
    the next :meth:`run` then raises until :meth:`reset`.
    """

    def __init__(self, model, sample_rate_hz):
        self._sim = _hystid.Simulation(_as_model(model), float(sample_rate_hz))

    def run(self, force, output="displacement", progress=None):
        """The response to the next block of ``force`` (N), continuing from
        where the last block left the structure and its joint; ``output``
        and ``progress`` as :func:`simulate`'s."""
        f = _f64(force, "force")
        if output == "all":
            return dict(zip(OUTPUTS, self._sim.run_all(f, progress)))
        return self._sim.run(f, output, progress)

    def reset(self):
        """Back to rest: the structure still, the joint virgin."""
        self._sim.reset()

    @property
    def samples(self):
        """Samples run since rest."""
        return self._sim.samples

    @property
    def sample_rate_hz(self):
        return self._sim.sample_rate_hz

    def __repr__(self):
        return f"hystid.Simulation(at {self.sample_rate_hz} Hz, {self.samples} samples run)"


def virtual_test(definition=None, check_hb=False, progress=None):
    """A virtual stepped-sine test, as ``hystid simulate`` runs it, in memory.

    ``definition``: a test definition (TOML text, a ``pathlib.Path``, or a dict; the
    embedded default, :data:`DEFAULT_TEST`, when ``None``). ``check_hb``
    also computes the harmonic-balance prediction at every dwell
    (``--check-hb``).

    Returns a dict: ``signals`` (``force``, ``displacement``, ``velocity``,
    ``acceleration``: float32 arrays, the samples ``recording.wav`` holds),
    ``recording`` (``recording.json``: sample rate, channels, the dwells'
    ``excitation.steps``), ``frf`` (``frf.json``), ``summary``
    (``summary.json``, without files), ``hb_check`` (``hb_check.json``, or
    ``None``), and ``definition`` (the TOML text).

    ``progress``: see :data:`PROGRESS` (here one event per dwell).
    """
    if definition is None:
        text, origin = None, None
    else:
        text, origin = _definition_text(definition)
    text, meta, frf, summary, hb, channels = _hystid.virtual_test(text, origin, check_hb, progress)
    meta = json.loads(meta)
    names = [c["name"] for c in meta["channels"]]
    return {
        "signals": dict(zip(names, channels)),
        "recording": meta,
        "frf": json.loads(frf),
        "summary": json.loads(summary),
        "hb_check": None if hb is None else json.loads(hb),
        "definition": text,
    }


def _excitation(steps, sweep):
    """recording.json's `excitation` of the given steps or sweep."""
    kind = "swept-sine" if sweep is not None else ("stepped-sine" if steps else "unknown")
    e = {"kind": kind, "steps": list(steps or [])}
    if sweep is not None:
        e["sweep"] = sweep
    return json.dumps(e)


def _reduction(excitation, max_harmonic, compensation, hop_periods, window_periods):
    return {
        "excitation": excitation,
        "max_harmonic": max_harmonic,
        "compensation": compensation,
        "hop_periods": float(hop_periods),
        "window_periods": int(window_periods),
    }


def extract(
    force,
    response,
    sample_rate_hz,
    *,
    steps=None,
    sweep=None,
    excitation=None,
    response_quantity="displacement",
    reference_quantity="force",
    max_harmonic=None,
    compensation="auto",
    hop_periods=1.0,
    window_periods=4,
    progress=None,
):
    """Nonlinear FRFs (``frf.json``) of a force (or voltage) and a response
    sampled at ``sample_rate_hz``, reduced as ``hystid identify`` reduces a
    recording.

    ``steps``: the dwells, as ``recording.json``'s ``excitation.steps``
    (dicts with ``frequency_hz``, ``level``, ``start``, ``settle``,
    ``length``); without them the dwells are found. ``sweep``: a sweep's
    known ``f_start_hz``, ``f_end_hz``. ``excitation``: ``"stepped"``,
    ``"swept"`` or ``None`` (swept when a ``sweep`` is given, else stepped).
    The other options are the command's reduction flags. ``progress``: see
    :data:`PROGRESS` (``"reducing"``).
    """
    frf = _hystid.extract(
        _f64(force, "force"),
        reference_quantity,
        _f64(response, "response"),
        response_quantity,
        float(sample_rate_hz),
        _excitation(steps, sweep),
        json.dumps(_reduction(excitation, max_harmonic, compensation, hop_periods, window_periods)),
        progress,
    )
    return json.loads(frf)


def _options(options, kwargs):
    o = dict(options or {})
    o.update(kwargs)
    if "band_hz" in o and o["band_hz"] is not None:
        o["band_hz"] = _band(o["band_hz"])
    return json.dumps(o)


def identify(
    frf,
    *,
    reference=None,
    recording="",
    response=None,
    options=None,
    domain="frf",
    recordings=None,
    start=None,
    response_sign=1,
    progress=None,
    **kwargs,
):
    """Fits a joint model to nonlinear FRFs (a dict as :func:`extract`,
    :func:`virtual_test` or ``frf.json`` give): the ``fit.json`` dict.

    ``start`` (anything :func:`model` takes): fit that model as written
    down instead, every parameter of its modes, joint and effects (a
    shaker, a hysteretic mode), as ``hystid identify --start MODEL`` does;
    ``response_sign=-1`` for a transfer whose modal constant is negative.
    The dict then has ``frequency_domain``.

    Fit options are the library's ``FitOptions`` fields, as keywords or an
    ``options`` dict: ``element`` (``"masing"``, ``"jenkins"``,
    ``"iwan4"``, ``"bouc_wen"``: its ``beta`` held), ``harmonics`` (``[1]``), ``weighting`` (``"none"`` or
    ``"standard_error"``: ``--weighted``), ``refine_linear``,
    ``linear_start``, ``modes``, ``second_optimiser`` (``--lm``),
    ``bootstrap``, ``seed`` (``--bootstrap-seed``), ``band_hz`` (``(lo,
    hi)``: ``--band``), ``max_iterations``. ``reference``: the structure the
    data came from (anything :func:`model` takes), for the ``comparison``.
    ``recording`` and ``response`` name the data in the report.

    ``domain="time"`` (``--domain time``) then refines the fit on the time
    histories ``recordings`` (a list as :func:`identify_time` takes): the
    ``fit.json`` dict with its ``time_domain``.

    ``progress``: see :data:`PROGRESS` (one event per cost evaluation).
    """
    if domain not in ("frf", "time"):
        raise HystidError(f"domain: `{domain}` is not frf or time")
    if domain == "time" and not recordings:
        raise HystidError("domain='time': give the time histories as recordings=[...]")
    opts = _options(options, kwargs)
    if start is not None:
        if domain != "frf":
            raise HystidError("start: a model written down is fitted here to the FRFs; use identify_time(start=...) for the time domain")
        text = _hystid.identify_declared(
            json.dumps(frf), _as_model(start), opts, float(response_sign), recording, response, progress
        )
        return json.loads(text)
    ref = None if reference is None else _as_model(reference)
    text = _hystid.identify(json.dumps(frf), opts, ref, recording, response, progress)
    fit = json.loads(text)
    if domain == "frf":
        return fit
    return identify_time(recordings, fit=fit, options=json.loads(opts), progress=progress)


def _time_record(r, i):
    """One recording of :func:`identify_time` as the library's arguments."""
    if not isinstance(r, dict) or "force" not in r or "response" not in r or "sample_rate_hz" not in r:
        raise HystidError(
            f"recordings[{i}]: a dict with force, response and sample_rate_hz "
            "(and steps, sweep, excitation, response_quantity, reference_quantity, name)"
        )
    e = json.loads(_excitation(r.get("steps"), r.get("sweep")))
    kind = r.get("excitation")
    if kind is not None:
        kinds = {"stepped": "stepped-sine", "swept": "swept-sine", "unknown": "unknown"}
        if kind not in kinds:
            raise HystidError(f"recordings[{i}].excitation: `{kind}` is not stepped, swept or unknown")
        e["kind"] = kinds[kind]
    return (
        _f64(r["force"], f"recordings[{i}].force"),
        r.get("reference_quantity", "force"),
        _f64(r["response"], f"recordings[{i}].response"),
        r.get("response_quantity", "displacement"),
        float(r["sample_rate_hz"]),
        json.dumps(e),
        str(r.get("name", f"recording {i + 1}")),
    )


_RECORDING_LISTS = (
    "references", "reference_quantities", "responses", "response_quantities",
    "sample_rates", "excitations", "names",
)


def _time_records(recordings):
    """The recordings of a time-domain call as the binding takes them (a
    dict of seven lists, one entry per recording)."""
    if isinstance(recordings, dict):
        recordings = [recordings]
    lists = list(zip(*[_time_record(r, i) for i, r in enumerate(recordings)])) or [[]] * 7
    return {k: list(v) for k, v in zip(_RECORDING_LISTS, lists)}


def identify_time(
    recordings,
    *,
    fit=None,
    start=None,
    fix=(),
    window_s=None,
    min_samples_per_period=40.0,
    options=None,
    progress=None,
    replay="band_limited",
    starts=1,
    max_judged_samples=2**20,
    acquisition=None,
    each_alone=False,
    **kwargs,
):
    """Fits a model to recorded time histories, as ``hystid identify
    --domain time`` does: the model driven by each measured force, its
    response matched sample by sample (the ``fit.json`` dict).

    ``recordings``: a list of dicts with ``force``, ``response`` (numpy or
    sequences), ``sample_rate_hz``, and optionally ``steps`` / ``sweep`` (as
    in :func:`extract`), ``excitation`` (``"stepped"``, ``"swept"`` or
    ``"unknown"``), ``response_quantity`` (``"displacement"``),
    ``reference_quantity`` (``"force"``) and ``name``.

    The start: ``fit`` (a ``fit.json`` dict of an FRF fit, refined as
    ``--domain time`` refines it), ``start`` (a model, anything
    :func:`model` takes: ``--start``, with ``fix``, ``window_s`` and
    ``min_samples_per_period`` as ``--fix``, ``--window`` and
    ``--min-samples-per-period``), or neither for multisines (a force that
    repeats: the linear estimate at the excited lines, the joint of
    ``element`` nearly linear). Fit options as in :func:`identify`
    (``element``, ``band_hz``: what is judged). ``progress``: see
    :data:`PROGRESS` (one event per replay of the recordings).
    ``replay="continuous"`` is ``--replay continuous`` (see :func:`validate`);
    ``starts=N`` is ``--starts N`` (descend from N starts spread about the
    given one, keep the lowest misfit; ``time_domain.starts`` lists them).
    ``max_judged_samples`` is ``--max-judged-samples`` (at least 1000): a
    fit that would judge more samples judges the responses low-passed at a
    lower rate, never below 8 samples a period of the model's highest
    frequency; ``time_domain.samples`` is the count judged.
    ``acquisition`` is ``--acquisition``: how the recorded response was
    decimated to the recording's rate, put through by every replay (a
    factor, a list of stages' factors such as ``[2, 2, 5]``, or a dict as
    the model file's ``[acquisition]``: ``{"decimated_by": 20, "taps":
    31}``); ``time_domain.acquisition`` keeps it for :func:`validate`.
    ``each_alone=True`` is ``--each-alone``: after a fit of several
    recordings, each is refitted alone from the fitted model
    (``time_domain.each_alone``, and a note on what it says).
    """
    parts = _time_records(recordings)
    model_start = None if start is None else _as_model(start)
    text = _hystid.identify_time(
        parts,
        _options(options, kwargs),
        None if fit is None else json.dumps(fit),
        model_start,
        [str(f) for f in fix],
        None if window_s is None else (float(window_s[0]), float(window_s[1])),
        float(min_samples_per_period),
        progress,
        replay,
        int(starts),
        int(max_judged_samples),
        _acquisition(acquisition),
        bool(each_alone),
    )
    return json.loads(text)


def _acquisition(chain):
    """A response's acquisition chain as the bindings take it (JSON), or
    ``None``."""
    if chain is None:
        return None
    if isinstance(chain, dict):
        return json.dumps(chain)
    if isinstance(chain, (int, np.integer)):
        return json.dumps({"decimated_by": int(chain)})
    return json.dumps({"decimated_by": [int(r) for r in chain]})


def diagnose(
    frf,
    fit=None,
    *,
    candidates=None,
    options=None,
    progress=None,
    recordings=None,
    reduction=None,
    time_proposals=0,
    replay="band_limited",
    starts=1,
    min_samples_per_period=40.0,
    max_judged_samples=2**20,
    acquisition=None,
    each_alone=False,
    **kwargs,
):
    """Traces a fit's residual to missing effects, adds them and refits, as
    ``hystid diagnose`` does: the ``diagnosis.json`` dict.

    ``fit``: a ``fit.json`` dict (as :func:`identify` returns), or ``None``
    to fit ``frf`` first with the fit options (keywords as in
    :func:`identify`). ``candidates``: effect names (default:
    ``second_mode``, ``cubic_stiffness``, ``bilinear_stiffness``,
    ``quadratic_damping``, ``clearance``, ``iwan4_joint``: an Iwan joint
    in place of the fitted joint law; ``hysteretic_mode``, a further mode
    with a joint of its own, where the model leaves more than twice the
    noise; ``shaker``, the coil's lag and back-EMF between a voltage
    reference and the structure, for a voltage reference only;
    ``bouc_wen_joint``, a Bouc-Wen joint in its place, is tried when named;
    ``"all"`` names every one). ``progress``: see :data:`PROGRESS`.

    ``recordings`` (a list as :func:`identify_time` takes, the stepped or
    swept sines ``frf`` was reduced from): the final model is then refined
    on their time histories, as ``diagnose --domain time`` does (the dict's
    ``time_domain``): each kept effect confirmed there, the time residual
    read in the FRFs' plane with the recordings reduced again as
    ``reduction`` says (:func:`extract`'s keywords: ``max_harmonic``,
    ``compensation``, ``hop_periods``, ``window_periods``, ``excitation``),
    and ``time_proposals``, ``replay``, ``starts``,
    ``min_samples_per_period`` and ``max_judged_samples`` as the command's
    ``--time-proposals``, ``--replay``, ``--starts``,
    ``--min-samples-per-period`` and ``--max-judged-samples`` (see
    :func:`identify_time`); ``acquisition`` as ``--acquisition`` (see
    :func:`identify_time`: the refits' replays through the response's
    decimation); ``each_alone=True`` as ``--each-alone`` (the final refit's
    recordings each refitted alone: ``time_domain.refit.each_alone``).
    """
    if recordings is None and reduction is not None:
        raise HystidError("reduction: reads the recordings again; give recordings=[...]")
    # the options go to the library as given, which refuses those of the
    # time domain without recordings
    time = dict(
        recordings=None if recordings is None else _time_records(recordings),
        reduction=json.dumps(reduction or {}),
        replay=replay,
        starts=int(starts),
        min_samples_per_period=float(min_samples_per_period),
        time_proposals=int(time_proposals),
        max_judged_samples=int(max_judged_samples),
        acquisition=_acquisition(acquisition),
        each_alone=bool(each_alone),
    )
    text = _hystid.diagnose(
        json.dumps(frf),
        _options(options, kwargs),
        None if fit is None else json.dumps(fit),
        _names(candidates),
        progress,
        time,
    )
    return json.loads(text)


def diagnose_time(
    recordings,
    *,
    candidates=None,
    time_proposals=0,
    min_samples_per_period=40.0,
    options=None,
    progress=None,
    replay="band_limited",
    starts=1,
    max_judged_samples=2**20,
    acquisition=None,
    **kwargs,
):
    """Diagnoses multisine recordings on the lines of their period, as
    ``hystid diagnose --domain time`` does on multisines: the joint of
    ``element`` on their linear estimate fitted in the time domain, its
    residual read at the lines (excited, odd and even not excited, in units
    of the noise the periods' scatter gives), every candidate traced there,
    the best refitted and added (the ``diagnosis.json`` dict, whose
    ``model`` is the final model).

    ``recordings``: as in :func:`identify_time`. ``candidates``: as in
    :func:`diagnose`. ``time_proposals``: the traced candidates refitted per
    round (0: 3). ``starts``: the baseline's starts (``--starts``: the given
    one and ``starts - 1`` spread about it). Fit options as in
    :func:`identify` (``element``, ``modes``). ``progress``: see
    :data:`PROGRESS`. ``max_judged_samples``: as in :func:`identify_time`
    (``--max-judged-samples``), for every fit the diagnosis makes;
    ``acquisition`` as there (``--acquisition``).
    """
    parts = _time_records(recordings)
    text = _hystid.diagnose_time(
        parts,
        _options(options, kwargs),
        _names(candidates),
        int(time_proposals),
        float(min_samples_per_period),
        progress,
        replay,
        int(starts),
        int(max_judged_samples),
        _acquisition(acquisition),
    )
    return json.loads(text)


def fit_coil(voltage, force, motion, sample_rate_hz, *, steps, motion_quantity="velocity"):
    """The shaker's coil from a stepped recording that holds the amplifier's
    voltage, the force the shaker applies (a force gauge between it and the
    structure) and the drive point's motion, as ``hystid identify`` reports
    it in ``fit.json``'s ``coil``: ``r`` (ohm), ``l`` (H), ``bl`` (N/A), the
    shaker model's ``ce`` (Bl^2/R), ``te`` (L/R) and ``gain`` (Bl/R), the
    ``dwells`` used and the equations' relative ``residual``.

    At each dwell's fundamental the coil obeys ``F (1 + j w te) = gain e -
    ce v``, two real equations linear in ``(gain, ce, te)``, solved by least
    squares over the dwells. ``steps``: the dwells, as in :func:`extract`
    (their ``settle`` frames are left out); ``motion_quantity``:
    ``"velocity"``, ``"displacement"`` or ``"acceleration"``.
    """
    text = _hystid.fit_coil(
        _f64(voltage, "voltage"),
        _f64(force, "force"),
        _f64(motion, "motion"),
        motion_quantity,
        float(sample_rate_hz),
        _excitation(steps, None),
    )
    return json.loads(text)


def validate(
    fit,
    force,
    response,
    sample_rate_hz,
    *,
    steps=None,
    sweep=None,
    excitation=None,
    response_quantity="displacement",
    reference_quantity="force",
    linear=False,
    band_hz=None,
    window_s=None,
    min_samples_per_period=20.0,
    frf=True,
    periodic=False,
    max_harmonic=None,
    compensation="auto",
    hop_periods=1.0,
    window_periods=4,
    fit_name="",
    recording="",
    replay="band_limited",
    progress=None,
    acquisition=None,
):
    """Drives a fitted model (a ``fit.json`` dict) with a measured force and
    compares the simulated response with the measured one, as ``hystid
    validate`` does: the ``validate.json`` dict with this one recording,
    whose entry also holds the ``simulated`` response (numpy).

    ``linear`` validates the fit's linear model instead (``--linear``);
    ``band_hz``, ``window_s``, ``min_samples_per_period``, ``frf=False``
    (``--no-frf``), ``periodic`` (``--periodic``: the recording is one period
    of a steady state) and the reduction options are the command's flags;
    ``fit`` is either kind of ``fit.json`` (an FRF fit's, or ``identify
    --domain time --start``'s);
    ``steps``, ``sweep`` as in :func:`extract`; ``replay="continuous"`` is
    ``--replay continuous`` (the joint's force taken as band-limited too, its
    ``sinc²`` loss inside the simulator's loop compensated). ``progress``:
    see :data:`PROGRESS` (``"simulating"``, then the FRF comparison's
    reductions). ``acquisition`` is ``--acquisition`` (as in
    :func:`identify_time`), in place of the fit's own.
    """
    settings = {
        "replay": replay,
        "band_hz": _band(band_hz),
        "window_s": None if window_s is None else list(window_s),
        "min_samples_per_period": float(min_samples_per_period),
        "frf": bool(frf),
        "periodic": bool(periodic),
        "reduction": _reduction(excitation, max_harmonic, compensation, hop_periods, window_periods),
    }
    chain = _acquisition(acquisition)
    if chain is not None:
        settings["acquisition"] = json.loads(chain)
    text, simulated = _hystid.validate(
        json.dumps(fit),
        bool(linear),
        _f64(force, "force"),
        reference_quantity,
        _f64(response, "response"),
        response_quantity,
        float(sample_rate_hz),
        _excitation(steps, sweep),
        json.dumps(settings),
        fit_name,
        recording,
        progress,
    )
    report = json.loads(text)
    report["recordings"][0]["simulated"] = simulated
    return report


def identify_points(
    recordings,
    out,
    responses,
    *,
    drive=None,
    joint="own",
    law="masing",
    band_hz=None,
    modes=3,
    outside_hz=(),
    excitation=None,
    max_harmonic=None,
    compensation="auto",
    hop_periods=1.0,
    window_periods=4,
    progress=None,
):
    """Fits a structure seen at several sensors and one joint to every
    sensor's FRFs at once, as ``hystid identify-points`` does: the
    ``points.json`` dict, with points.md and a figure per sensor written
    into ``out``.

    ``recordings``: paths of recordings that each hold the force and every
    channel of ``responses`` (one sensor each, in point order); ``drive``:
    the response at the drive point (the first by default); ``joint``:
    ``"A:B"`` between two responses, ``"A:ground"``, or ``"own"`` (a
    coordinate no sensor reads, the joint several modes share);
    ``band_hz``: ``(lo, hi)`` or ``"lo:hi"``; ``modes`` at the band's peaks
    and ``outside_hz`` held outside it; the reduction options as in
    :func:`extract`. ``progress``: see :data:`PROGRESS` (``"reducing"``,
    ``"fitting"``).
    """
    band = _band(band_hz)
    text = _hystid.identify_points(
        [str(recordings)] if isinstance(recordings, (str, os.PathLike)) else [str(r) for r in recordings],
        str(out),
        [str(r) for r in _names(responses)],
        drive,
        joint,
        law,
        None if band is None else f"{band[0]}:{band[1]}",
        int(modes),
        [float(f) for f in outside_hz],
        json.dumps(_reduction(excitation, max_harmonic, compensation, hop_periods, window_periods)),
        progress,
    )
    return json.loads(text)


def frf_arrays(frf):
    """Nonlinear FRFs (``frf.json``, or ``virtual_test()["frf"]``) as numpy
    arrays, level x frequency x harmonic.

    Returns a dict: ``level`` (the nominal levels), ``direction``,
    ``frequency_hz`` and ``force_amplitude`` (level x point), ``h`` (complex,
    level x point x harmonic, ``h[..., k]`` the k-th harmonic's FRF ``H_k``,
    ``H_0`` the mean) and ``std_error`` (its standard error, same shape).
    Levels with fewer points than the longest are padded with NaN.
    """
    levels = frf["levels"]
    n_points = max((len(l["points"]) for l in levels), default=0)
    n_harmonics = int(frf["max_harmonic"]) + 1
    shape = (len(levels), n_points)
    out = {
        "level": np.array([l["level"] for l in levels], dtype=float),
        "direction": [l.get("direction") for l in levels],
        "frequency_hz": np.full(shape, np.nan),
        "force_amplitude": np.full(shape, np.nan),
        "h": np.full(shape + (n_harmonics,), np.nan, dtype=complex),
        "std_error": np.full(shape + (n_harmonics,), np.nan),
    }
    for i, level in enumerate(levels):
        for j, p in enumerate(level["points"]):
            out["frequency_hz"][i, j] = p["frequency_hz"]
            out["force_amplitude"][i, j] = p["force_amplitude"]
            h = np.asarray(p["h"], dtype=float)
            out["h"][i, j, : len(h)] = h[:, 0] + 1j * h[:, 1]
            se = np.asarray(p["std_error"], dtype=float)
            out["std_error"][i, j, : len(se)] = se
    return out


def parameters_table(result):
    """A fit's or a diagnosis's parameters as a table: a pandas DataFrame
    (index: the parameter) when pandas is installed, else a dict of columns.

    Columns: ``value``, ``ci95_low``, ``ci95_high`` (NaN where the interval
    has no end or was not computed) and ``identifiable``.
    """
    params = result.get("parameters")
    if params is None and isinstance(result.get("final"), dict):
        params = result["final"].get("parameters")
    if params is None:
        raise HystidError("no `parameters` in this result (expected a fit or a diagnosis)")
    names = list(params)
    rows = [p if isinstance(p, dict) else {"value": p} for p in params.values()]
    end = lambda r, k: np.nan if r.get("ci95") is None or r["ci95"][k] is None else float(r["ci95"][k])
    columns = {
        "value": np.array([float(r["value"]) for r in rows]),
        "ci95_low": np.array([end(r, 0) for r in rows]),
        "ci95_high": np.array([end(r, 1) for r in rows]),
        "identifiable": [r.get("identifiable") for r in rows],
    }
    try:
        import pandas as pd
    except ImportError:
        return {"parameter": names, **columns}
    return pd.DataFrame(columns, index=pd.Index(names, name="parameter"))
