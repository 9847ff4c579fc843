"""Type stubs of crandall's compiled core (private; use the crandall package)."""

from typing import Any, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

#: Paths per chunk: the unit of work, of checkpoints and of Dask tasks.
CHUNK_PATHS: int
#: Paths per block inside a chunk (the unit one thread works on).
BLOCK_PATHS: int
#: SIMD lanes of the path loop.
LANES: int
#: The methods' table (plan.hpp, kMethodTable): per method, in the core's order, (name, number
#: of coupled grids, whether its steps are the exact skeleton's, order of its bias; NaN: unknown).
METHOD_TABLE: Tuple[Tuple[str, int, bool, float], ...]
#: Name -> number of coupled grids, from METHOD_TABLE.
METHOD_GRIDS: dict[str, int]
#: Histogram variables per slot, in the order of Options.histogram_axes.
HISTOGRAM_VARIABLES: int
#: The quantities whose splitting score the core computes, in the order of split.hpp's
#: SplitQuantity (split_replica's `quantity` is an index into it).
SPLIT_QUANTITIES: Tuple[str, ...]

def monomial_exponents() -> List[Tuple[int, int, int]]:
    """Exponent triples (a, b, c) of the central sums, in storage order."""

class Options:
    """Options of a run (validated by Plan)."""

    drift: float
    noise: float
    switch_off: float
    piece_ends: List[float]
    piece_noise: List[float]
    residual: bool
    quadratic_variation: bool
    start_velocity: float
    start_displacement: float
    times: List[float]
    dt: float
    #: Graded grid: the step before time t is at most t / min_steps (0: off).
    min_steps: int
    #: Nested grids: every segment's step count times 2^refinement (0 to 30).
    refinement: int
    method: str
    velocity: bool
    displacement: bool
    distance: bool
    stop: bool
    #: Record the running maxima of |velocity| and |displacement| (ChunkResult.peaks).
    peaks: bool
    #: Record the moments of V^2 per output time (ChunkResult.energy).
    energy: bool
    #: Empty, or one axis per (slot, variable): (len(times) + stop) * 5, index slot * 5 +
    #: variable; an axis with 0 bins is not recorded.
    histogram_axes: List[BinEdges]
    seed: int
    paths: int
    #: "white" (the default) or "filtered": a_g = c . z of dz = A z dt + b noise dW.
    excitation: str
    #: The filter (excitation "filtered"): A (n x n row-major), b, c (n each), z(0) (empty: 0).
    filter_a: List[float]
    filter_b: List[float]
    filter_c: List[float]
    filter_start: List[float]
    #: Static friction deceleration, >= drift; NaN: equal to drift.
    static_drift: float
    #: Bisections of a step where an event may happen (1 to 20).
    event_depth: int
    #: The switch-off ends only the driving noise (the filter rings down), not the shaking.
    ring_down: bool
    def __init__(self) -> None: ...
    def validate(self) -> None: ...

class Plan:
    """A validated run: the time grid and the path partition."""

    def __init__(self, options: Options) -> None: ...
    @property
    def steps_per_path(self) -> int: ...
    @property
    def chunks(self) -> int: ...
    def chunk_paths(self, chunk: int) -> int: ...
    @property
    def options(self) -> Options: ...

class Moments:
    """Count, means and central sums up to order 4 of three variables per slot."""

    def __init__(
        self,
        slots: int,
        counts: npt.ArrayLike = ...,
        means: npt.ArrayLike = ...,
        central: npt.ArrayLike = ...,
    ) -> None: ...
    @property
    def slots(self) -> int: ...
    @property
    def counts(self) -> npt.NDArray[np.float64]: ...
    @property
    def means(self) -> npt.NDArray[np.float64]: ...
    @property
    def central(self) -> npt.NDArray[np.float64]: ...
    def raw(self) -> npt.NDArray[np.float64]: ...
    def merge(self, other: Moments) -> None: ...
    def __getstate__(self) -> Tuple[Any, ...]: ...
    def __setstate__(self, state: Tuple[Any, ...]) -> None: ...

class BinEdges:
    """The edges of one histogram axis; bins [e_j, e_j+1); cells = bins + 3 (underflow, the
    bins, overflow, NaN); 0 bins: not recorded."""

    def __init__(self) -> None: ...
    @staticmethod
    def log_linear(scale: float, per_octave: int, max_scales: float,
                   symmetric: bool) -> BinEdges: ...
    @staticmethod
    def from_edges(edges: npt.ArrayLike) -> BinEdges: ...
    @property
    def edges(self) -> npt.NDArray[np.float64]: ...
    @property
    def bins(self) -> int: ...
    @property
    def cells(self) -> int: ...
    @property
    def automatic(self) -> bool: ...
    @property
    def base(self) -> float: ...
    @property
    def per_octave(self) -> int: ...
    @property
    def symmetric(self) -> bool: ...
    def cell(self, x: float) -> int: ...
    def count(self, values: npt.ArrayLike) -> npt.NDArray[np.uint64]:
        """The cells' counts of an array of values, with the run's own lookup."""
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...

class ChunkResult:
    @property
    def times(self) -> Moments: ...
    @property
    def stop(self) -> Moments: ...
    @property
    def peaks(self) -> Moments: ...
    @property
    def peaks_stop(self) -> Moments: ...
    @property
    def energy(self) -> Moments: ...
    @property
    def histogram_counts(self) -> List[npt.NDArray[np.uint64]]: ...

def run_chunk(plan: Plan, chunk: int, threads: int = 0) -> ChunkResult:
    """Simulate one chunk of paths; bitwise the same for any thread count."""

def set_thread_work(steps: float) -> float:
    """Set the least work (path steps) a thread of a parallel loop gets, for the process;
    returns the previous value. The tests set 1 (their runs are small)."""

def exact_steps(
    start: Union[Sequence[float], npt.NDArray[np.float64]],
    h: float,
    drift: float,
    noise: float,
    seed: int,
) -> npt.NDArray[np.float64]:
    """One exact velocity step of length h from each start value (path i uses stream i)."""

def extend_paths(
    states: npt.NDArray[np.float64],
    rows: Union[Sequence[int], npt.NDArray[np.int64]],
    starts: Union[Sequence[int], npt.NDArray[np.int64]],
    streams: Union[Sequence[int], npt.NDArray[np.uint64]],
    lengths: npt.NDArray[np.float64],
    noises: npt.NDArray[np.float64],
    drifts: npt.NDArray[np.float64],
    key: int,
    threads: int = 0,
    touched: Optional[npt.NDArray[np.uint8]] = None,
    slow: Optional[npt.NDArray[np.float64]] = None,
    slow_drifts: Optional[npt.NDArray[np.float64]] = None,
) -> None:
    """Continue rows of states (rows x (steps + 1) x 3) from grid point starts[i] with the
    noise of stream streams[i] of key; in place (the rare-event estimators' paths). touched
    (rows x steps) receives whether each step taken reached 0; a step that starts with
    |x| < slow[k] takes the drift slow_drifts[k] instead of drifts[k]."""

def extend_filtered_paths(
    plan: Plan,
    states: npt.NDArray[np.float64],
    rows: Union[Sequence[int], npt.NDArray[np.int64]],
    starts: Union[Sequence[int], npt.NDArray[np.int64]],
    streams: Union[Sequence[int], npt.NDArray[np.uint64]],
    key: Optional[int] = None,
    threads: int = 0,
) -> None:
    """Continue rows of states (rows x points x (4 + n): V, U, S, the last arrival at rest, z)
    of a filtered plan's walked grid from grid point starts[i] with the numbers of path
    streams[i] (< 2^40) under key (default: the plan's seed); in place, the same bits for any
    thread count (crandall.tail's splitting)."""

def filtered_grid(
    plan: Plan,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(lengths, noises, z0) of a filtered plan's walked grid: every step's length and
    intensity, and the filter's start state."""

#: The ground features per path and slot of a filtered plan's control sums.
GROUND_FEATURES: int
BODY_CONTROLS: int
BODY_PRODUCTS: int
BODY_SECOND_ORDER: int

def set_event_margin(margin: float) -> float:
    """Sets the filtered event search's margin (a diagnostic); returns the previous one."""

def ground_feature_means(plan: Plan) -> npt.NDArray[np.float64]:
    """The exact means of a filtered plan's ground features, (times + 1) x GROUND_FEATURES
    (the stop's row last)."""

def det_exp(x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """exp(x) elementwise with the same bits on every CPU (fdlibm's algorithm with +, -, *, /
    only): +inf above 709.78, 0 below -745.13, NaN for NaN."""

def det_log(x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """log(x) elementwise with the same bits on every CPU: -inf at 0, ValueError below 0."""

def det_log1p(x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """log(1 + x) elementwise with the same bits on every CPU: -inf at -1, ValueError below."""

def det_log_erfc(x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """log(erfc(x)) elementwise with the same bits on every CPU, without underflow for large x
    (-inf only where -x^2 overflows)."""

def split_parents(
    key: int, replica: int, iteration: int, survivors: int, count: int
) -> npt.NDArray[np.int64]:
    """The parents of one splitting iteration's count clones: indices uniform on
    [0, survivors), drawn from Philox keyed by (key, replica, iteration)."""

def tail_grid(
    plan: Plan,
    dt: float,
    coarse: bool = ...,
    max_steps: float = ...,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(lengths, noises, starts) of a tail run's grid on a white-noise plan: each segment cut
    into max(1, ceil(length / dt - 1e-9)) equal steps (one without noise or when `coarse`);
    ValueError starting with 'dt:' past `max_steps` steps in a segment."""

def split_replica(
    lengths: npt.NDArray[np.float64],
    noises: npt.NDArray[np.float64],
    drifts: npt.NDArray[np.float64],
    key: int,
    replicas: Sequence[int],
    particles: int,
    kill: int,
    max_iterations: int,
    deadline: Optional[float],
    v0: float,
    u0: float,
    first: int,
    levels: npt.NDArray[np.float64],
    thresholds: npt.NDArray[np.float64],
    quantity: int,
    drift: float,
    horizon: float,
    coast: float,
    mass: float,
    remaining: npt.NDArray[np.float64],
    uncoast: bool,
    top: Optional[float],
    normaliser: Optional[Tuple[Any, ...]],
    threads: int = 1,
) -> List[Tuple[npt.NDArray[np.float64], int, int, float, bool, bool]]:
    """Replicas of adaptive multilevel splitting on a white-noise grid, in step (each the bits
    it has alone): per replica (estimates, iterations, steps, log_weight, extinct, timed_out).
    The GIL is released."""

def random_floor(paths: int, steps: int, seed: int, threads: int = 0) -> float:
    """Generate the kernel's noise for paths x steps with no physics (a throughput floor)."""

RANDOM_STREAM: int
TOUCH_DEPTH: int
#: Control sums per path and slot of run_samples(controls=True).
CONTROLS: int
WHITE_CONTROLS: int

def build_info() -> dict[str, Union[int, str, list[str]]]:
    """What runs: the kernel variant in use (isa: CRANDALL_ISA or the best the CPU supports), the
    variants compiled in and those supported here, Philox paths and doubles per register, the
    random-stream version, the compiler. Every variant gives the same numbers."""

def draw_noise(seed: int, path0: int, count: int, pair: int) -> npt.NDArray[np.float64]:
    """Diagnostics: the kernel's draws of step pair `pair` for paths path0 .. path0 + count - 1,
    shape (6, count): normals of steps 2 pair and 2 pair + 1, their exponentials, their coins."""

def filtered_trajectory(plan: Plan, path: int) -> dict[str, npt.NDArray[np.float64]]:
    """One path of a filtered plan, point by point: keys t, a_g, V, U, S."""

def filter_transition(
    a: List[float], b: List[float], c: List[float], h: float
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(Phi, Q) of the filter augmented with G and D over a step h (unit intensity)."""

def filter_root_levels(
    a: List[float], b: List[float], c: List[float], longest: float, count: int
) -> List[Tuple[float, npt.NDArray[np.float64], npt.NDArray[np.float64]]]:
    """The noise tree's (length, Phi, R) at lengths longest / 2^i, i < count, R R^T = Q."""

def simulate_states(plan: Plan) -> npt.NDArray[np.float64]:
    """Diagnostics: every path's velocity at the end of the plan's last segment, velocity only,
    exact or Euler method, one thread, through the kernel in use."""


def richardson_weights(method: str) -> List[float]:
    """The weights that combine a method's coupled grids (steps h, 2h, 4h), finest first."""

def run_samples(plan: Plan, first: int, count: int, threads: int = 0,
                controls: bool = False, out: Optional[npt.NDArray[np.float64]] = None,
                controls_out: Optional[npt.NDArray[np.float64]] = None,
                control_slots: List[int] = ...) -> Any:
    """Per-path values, shape (count, slots, grids, 3) (slots: the output times, the stop, the
    quadratic variation, and a filtered plan's peaks, (max |V|, max |U|, 0) per output time and
    at the stop); with controls, (values, controls)
    with controls of shape (count, slots, CONTROLS), or (count, len(control_slots),
    CONTROLS) at the ascending slots control_slots only."""

def sum_products(values: npt.NDArray[np.float64], widths: List[int],
                 threads: int = 0) -> npt.NDArray[np.float64]:
    """Per group of consecutive columns: column sums and the upper triangle of F^T F."""

class FeatureColumns:
    """The feature columns of a run to an accuracy, one entry per column."""
    slot: List[int]
    variable: List[int]
    kind: List[int]
    power: List[int]
    constant: List[float]
    centre: List[float]
    inexact: List[int]
    control: List[int]
    beta: List[float]
    def __init__(self) -> None: ...

def form_features(samples: npt.NDArray[np.float64], columns: FeatureColumns, two_drift: float,
                  level: int, out: npt.NDArray[np.float64],
                  controls: Optional[npt.NDArray[np.float64]] = None,
                  threads: int = 0) -> npt.NDArray[np.float64]:
    """Into out (rows, columns): each column's value on the fine grid minus its centre, to its
    power; on level 0 minus its controls' multiples, on a finer level minus the coarse
    grid's (0 for columns exact in law)."""

MAX_HISTOGRAM_BINS: int

#: Standard gravity, m/s^2 (records' g; crandall.records.G).
STANDARD_GRAVITY: float

_Summary = Tuple[float, float, float, int]

def newmark_exact(
    acceleration: npt.NDArray[np.float64], dt: float, sign: float, kd: float, ku: float,
    sd: float, su: float,
) -> Tuple[_Summary, npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The exact block on one record (m/s^2; yields in m/s^2): ((displacement, max, min,
    slips), velocity, displacement, events (onset, stop, direction, stopped))."""

def newmark_slammer(
    acceleration: npt.NDArray[np.float64], dt: float, sign: float, ky: float,
) -> Tuple[_Summary, npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """pySLAMMER 0.2.2's rigid block on one record (m/s^2), ky in g; as newmark_exact."""

def newmark_sweep(
    records: Sequence[npt.NDArray[np.float64]], dts: Sequence[float],
    yields: npt.NDArray[np.float64], signs: Sequence[float], method: str, threads: int = 0,
) -> npt.NDArray[np.float64]:
    """Every (record, yield, sign): (records, yields, signs, 4) of (displacement, max, min,
    slips)."""
