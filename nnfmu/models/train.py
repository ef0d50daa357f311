"""Train a component network on one measurement: features from a spec, contiguous splits, several seeded restarts,
early stopping on validation, hidden size fixed or chosen by validation error, metrics on every split."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from typing import Literal

import numpy as np
import torch
from threadpoolctl import threadpool_limits

from nnfmu.data.denoise import lowpass_channels
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.errors import SettingsError
from nnfmu.models.cores import SpareCores, usable_cores
from nnfmu.models.features import FeatureSpec, Stop
from nnfmu.models.lm import Lend, LMSettings, check_input_coordinates, fit_lm
from nnfmu.models.metrics import SplitMetrics, max_abs_weight, network_warning, split_metrics
from nnfmu.models.networks import MLP, GRUNet
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.splits import SplitFractions, Splits, contiguous_splits
from nnfmu.models.stopping import FitHistory, TrainingLog
from nnfmu.models.trained import TrainedModel, trained_model
from nnfmu.stopping import check_stop

NetworkKind = Literal["mlp", "gru"]
Optimizer = Literal["auto", "lm", "adam", "lbfgs"]
# Progress callback: (what is running, fraction of the whole training done in [0, 1]).
Progress = Callable[[str, float], None]

# Levenberg–Marquardt solves a (weights x weights) system per epoch; above this many weights Adam is cheaper.
LM_MAX_WEIGHTS = 400
# torch intra-op threads while fitting with Adam, L-BFGS or the GRU (Levenberg-Marquardt runs in numpy, its BLAS held
# to one thread): the networks' matrices are small (tens of thousands of rows x tens of columns), so a second thread
# gains little on idle cores, and on loaded ones every small operation waits for a descheduled thread (OpenMP
# spinning): 40 LM epochs of the 4-12-1 damper net, when LM ran in torch, cost 13.4 s CPU and 179 s wall with 2
# threads at load 22 on 2 cores, 1.4 s CPU and 27 s wall with 1 (measured on branch h/lmtrain, 2026-11-27).
TRAINING_THREADS = 1
# A stop operator whose play the training split moves on fewer than this share of its samples is left out of the
# spec: it only copies its channel less the record's first value (the play never leaves where the record started), so
# a network using it ties its static force to the record's starting point instead of to where a relaxed start puts
# it. Road test (28 Nov): stops of 25-400 um in the axial force preset, trained on the vehicle-derived record, whose
# axial motion slips the 200 and 400 um ones never and the 100 um one on 1.1 % of its samples; relaxed at the rear
# bushing's working point (7 um from the record's start) the network gave 102 N where the truth gives 116.5 N, and
# the car's arm settled 6.5 um along its axis in the first 20 ms (front bushing axial force +7.3 N throughout, NRMSE
# 6.4 %); with the stops that slip (12.5-50 um: 17-61 % of the samples) the offset was gone.
MIN_STOP_SLIP = 0.02
# Hidden units per layer at most: component networks have tens; a batch of activations is samples x hidden floats
MAX_HIDDEN = 1024


@dataclass(frozen=True)
class Architecture:
    """Network kind and hidden size; several sizes mean "choose by validation error" (the smallest within tolerance)."""

    kind: NetworkKind = "mlp"
    hidden: tuple[int, ...] = (3,)

    def __post_init__(self) -> None:
        if self.kind not in ("mlp", "gru"):
            raise SettingsError(f"network kind must be 'mlp' or 'gru', got {self.kind!r}")
        hidden = tuple(self.hidden)
        if not hidden or any(isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 1 for h in hidden):
            raise SettingsError(f"hidden sizes must be integers >= 1, got {self.hidden!r}")
        if max(hidden) > MAX_HIDDEN:
            raise SettingsError(
                f"hidden size {max(hidden)} is more than the limit of {MAX_HIDDEN} units (component networks need tens)"
            )
        object.__setattr__(self, "hidden", tuple(sorted(set(int(h) for h in hidden))))


@dataclass(frozen=True)
class TrainSettings:
    """How to train. `optimizer` "auto" = Levenberg–Marquardt for MLPs up to LM_MAX_WEIGHTS weights, else Adam.

    max_epochs/patience: epoch limit and early-stopping patience on the validation split; restarts: seeded random
    initialisations per hidden size, the best validation error kept; hidden_tolerance: "auto" hidden size picks the
    smallest size whose validation MSE is within (1 + tolerance) of the best; lm_max_samples: LM fits on at most this
    many training samples (evenly strided); lm_inputs: the input coordinates LM steps in (`nnfmu.models.lm`:
    "raw" as trainlm, "standardised" or "whitened"); learning_rate/batch_size: Adam (batch_size samples per MLP step);
    chunk_length/burn_in/sequences_per_batch: GRU training sequences, the samples at their start left out of the loss
    while the hidden state settles, and sequences per Adam step; input_cutoff [Hz]: the input channels low-passed
    with zero phase before the features (`nnfmu.data.denoise`; None: as recorded).
    """

    optimizer: Optimizer = "auto"
    max_epochs: int = 500
    patience: int = 12
    restarts: int = 3
    seed: int = 0
    splits: SplitFractions = SplitFractions()
    hidden_tolerance: float = 0.10
    lm_max_samples: int = 20000
    lm_inputs: str = "raw"
    learning_rate: float = 0.01
    batch_size: int = 1024
    chunk_length: int = 500
    burn_in: int = 100
    sequences_per_batch: int = 32
    input_cutoff: float | None = None

    def __post_init__(self) -> None:
        if self.optimizer not in ("auto", "lm", "adam", "lbfgs"):
            raise SettingsError(f"optimizer must be auto, lm, adam or lbfgs, got {self.optimizer!r}")
        check_input_coordinates("lm_inputs", self.lm_inputs)
        for name in (
            "max_epochs",
            "patience",
            "restarts",
            "lm_max_samples",
            "batch_size",
            "chunk_length",
            "sequences_per_batch",
        ):
            if getattr(self, name) < 1:
                raise SettingsError(f"{name} must be >= 1, got {getattr(self, name)!r}")
        if not 0 <= self.burn_in < self.chunk_length:
            raise SettingsError(f"burn_in must be in [0, chunk_length={self.chunk_length}), got {self.burn_in}")
        if not (self.hidden_tolerance >= 0 and self.learning_rate > 0):
            raise SettingsError("hidden_tolerance must be >= 0 and learning_rate > 0")
        if self.input_cutoff is not None and not self.input_cutoff > 0:
            raise SettingsError(f"input_cutoff must be a positive frequency [Hz] or None, got {self.input_cutoff!r}")

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["splits"] = asdict(self.splits)
        return d


@dataclass
class PreparedData:
    """Feature matrix and target of the whole record (sequential from rest), their scalers (fitted on the training
    split only) and the scaled tensors the optimisers use."""

    features: np.ndarray
    target: np.ndarray
    feature_scaler: MinMaxScaler
    target_scaler: MinMaxScaler
    x: torch.Tensor
    y: torch.Tensor
    splits: Splits

    def rows(self, split: str) -> tuple[torch.Tensor, torch.Tensor]:
        index = torch.from_numpy(self.splits.index(split))
        return self.x[index], self.y[index]


@dataclass
class SizeTrial:
    """Best validation MSE (scaled) over the restarts of one hidden size."""

    hidden: int
    validation_mse: float
    best_restart: int


@dataclass
class TrainResult:
    """The trained model, its splits, each tried hidden size's validation error, the kept fit's history, warnings, and
    notes on what the training changed in the spec (stop operators left out)."""

    model: TrainedModel
    splits: Splits
    trials: list[SizeTrial]
    history: FitHistory
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def prepare_data(measurement: Measurement, spec: FeatureSpec, fractions: SplitFractions) -> PreparedData:
    """Features of `spec` over the record, split in time, scaled with the training split's extremes."""
    missing = [c for c in (*spec.channels, spec.output) if c not in measurement]
    if missing:
        raise DataError(
            f"{measurement.source}: channel(s) {missing} needed by the feature spec are missing"
            f" (has {measurement.names})"
        )
    features = spec.features({c: measurement[c] for c in spec.channels}, measurement.sample_period)
    target = np.asarray(measurement[spec.output], dtype=np.float64)
    splits = contiguous_splits(len(target), fractions)
    train = splits.index("train")
    if np.ptp(target[train]) == 0:
        raise DataError(f"{measurement.source}: output channel {spec.output!r} is constant over the training split")
    feature_scaler = MinMaxScaler.fit(features[train])
    target_scaler = MinMaxScaler.fit(target[train])
    return PreparedData(
        features=features,
        target=target,
        feature_scaler=feature_scaler,
        target_scaler=target_scaler,
        x=torch.from_numpy(feature_scaler.scale(features)),
        y=torch.from_numpy(target_scaler.scale(target)),
        splits=splits,
    )


def restart_seed(seed: int, hidden: int, restart: int) -> int:
    """Independent, reproducible seed for one (hidden size, restart) pair."""
    return int(np.random.SeedSequence([seed, hidden, restart]).generate_state(1)[0])


def _resolve_optimizer(kind: NetworkKind, n_in: int, hidden: int, optimizer: Optimizer) -> str:
    if kind == "gru":
        if optimizer in ("lm", "lbfgs"):
            raise SettingsError(f"optimizer {optimizer!r} is for MLPs; a GRU trains with Adam ('adam' or 'auto')")
        return "adam"
    if optimizer != "auto":
        return optimizer
    return "lm" if (n_in + 2) * hidden + 1 <= LM_MAX_WEIGHTS else "adam"


def _strided(x: torch.Tensor, y: torch.Tensor, limit: int) -> tuple[torch.Tensor, torch.Tensor]:
    step = max(1, math.ceil(len(y) / limit))
    return x[::step], y[::step]


def _fit_mlp_gradient(
    network: MLP, data: PreparedData, settings: TrainSettings, method: str, on_epoch: Callable[[int, int], None]
) -> FitHistory:
    """Adam on shuffled mini-batches, or full-batch L-BFGS, one epoch = one pass / one L-BFGS iteration."""
    x, y = data.rows("train")
    x_val, y_val = data.rows("validation")
    generator = torch.Generator().manual_seed(settings.seed)

    def mse(xs: torch.Tensor, ys: torch.Tensor) -> torch.Tensor:
        return torch.mean((network(xs)[:, 0] - ys) ** 2)

    with torch.no_grad():
        log = TrainingLog(network, settings.patience, float(mse(x, y)), float(mse(x_val, y_val)))
    if method == "lbfgs":
        optimiser: torch.optim.Optimizer = torch.optim.LBFGS(
            network.parameters(), max_iter=1, line_search_fn="strong_wolfe"
        )
    else:
        optimiser = torch.optim.Adam(network.parameters(), lr=settings.learning_rate)
    reason = "max_epochs"
    for epoch in range(1, settings.max_epochs + 1):
        check_stop()
        if method == "lbfgs":

            def closure() -> torch.Tensor:
                optimiser.zero_grad()
                loss = mse(x, y)
                loss.backward()
                return loss

            optimiser.step(closure)
        else:
            order = torch.randperm(len(y), generator=generator)
            for start in range(0, len(y), settings.batch_size):
                batch = order[start : start + settings.batch_size]
                optimiser.zero_grad()
                mse(x[batch], y[batch]).backward()
                optimiser.step()
        with torch.no_grad():
            stop = log.record(epoch, float(mse(x, y)), float(mse(x_val, y_val)))
        on_epoch(epoch, settings.max_epochs)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)


def _chunks(
    x: torch.Tensor, y: torch.Tensor, parts: tuple[slice, ...], length: int, burn_in: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Sequences covering the ranges `parts` for truncated back-propagation: x (B, length, f), y (B, length).

    Each sequence starts burn_in samples before the samples it scores (inputs only) so its hidden state has run in;
    y is NaN where a sample is not scored (burn-in, outside its range, end padding). Every sample is scored once.
    """
    scored = length - burn_in
    xs, ys = [], []
    for part, s in ((p, s) for p in parts for s in range(p.start, p.stop, scored)):
        lo = max(0, s - burn_in)
        hi = min(part.stop, lo + length)
        index = torch.arange(lo, hi)
        keep = (index >= s) & (index < s + scored)
        xc = torch.zeros(length, x.shape[1], dtype=x.dtype)
        yc = torch.full((length,), torch.nan, dtype=y.dtype)
        xc[: hi - lo] = x[lo:hi]
        yc[: hi - lo] = torch.where(keep, y[lo:hi], torch.nan)
        xs.append(xc)
        ys.append(yc)
    return torch.stack(xs), torch.stack(ys)


def _fit_gru(
    network: GRUNet, data: PreparedData, settings: TrainSettings, on_epoch: Callable[[int, int], None]
) -> FitHistory:
    """Adam on overlapping training sequences (truncated back-propagation through time), early stopping on validation
    sequences; losses count only samples after each sequence's burn-in and inside its split."""
    x_train, y_train = _chunks(data.x, data.y, data.splits.train, settings.chunk_length, settings.burn_in)
    x_val, y_val = _chunks(data.x, data.y, data.splits.validation, settings.chunk_length, settings.burn_in)
    generator = torch.Generator().manual_seed(settings.seed)

    def mse(xs: torch.Tensor, ys: torch.Tensor) -> torch.Tensor:
        scored = ~torch.isnan(ys)
        return torch.mean((network(xs)[..., 0][scored] - ys[scored]) ** 2)

    with torch.no_grad():
        log = TrainingLog(network, settings.patience, float(mse(x_train, y_train)), float(mse(x_val, y_val)))
    optimiser = torch.optim.Adam(network.parameters(), lr=settings.learning_rate)
    batch = settings.sequences_per_batch
    reason = "max_epochs"
    for epoch in range(1, settings.max_epochs + 1):
        check_stop()
        order = torch.randperm(len(x_train), generator=generator)
        total = 0.0
        for start in range(0, len(order), batch):
            pick = order[start : start + batch]
            optimiser.zero_grad()
            loss = mse(x_train[pick], y_train[pick])
            loss.backward()
            torch.nn.utils.clip_grad_norm_(network.parameters(), 1.0)
            optimiser.step()
            total += float(loss.detach()) * len(pick)
        with torch.no_grad():
            stop = log.record(epoch, total / len(order), float(mse(x_val, y_val)))
        on_epoch(epoch, settings.max_epochs)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)


def new_network(kind: NetworkKind, n_in: int, hidden: int, seed: int) -> MLP | GRUNet:
    """A network at its seeded random initialisation (torch's global generator: one thread at a time)."""
    torch.manual_seed(seed)
    return GRUNet(n_in, hidden) if kind == "gru" else MLP(n_in, hidden)


def fit_network(
    network: MLP | GRUNet,
    data: PreparedData,
    settings: TrainSettings,
    seed: int,
    on_epoch: Callable[[int, int], None] = lambda epoch, total: None,
    lend: Lend | None = None,
) -> FitHistory:
    """One training run of `network` from its initial weights; it ends holding its best validation epoch's.

    `lend`: where Levenberg–Marquardt may hand part of an epoch to a spare core (`SpareCores.lend`)."""
    hidden = network.gru.hidden_size if isinstance(network, GRUNet) else network.hidden.out_features
    method = _resolve_optimizer(
        "gru" if isinstance(network, GRUNet) else "mlp", data.x.shape[1], hidden, settings.optimizer
    )
    run_settings = replace(settings, seed=seed)
    if isinstance(network, GRUNet):
        return _fit_gru(network, data, run_settings, on_epoch)
    if method == "lm":
        lm = LMSettings(max_epochs=settings.max_epochs, patience=settings.patience, inputs=settings.lm_inputs)
        train = _strided(*data.rows("train"), settings.lm_max_samples)
        validation = _strided(*data.rows("validation"), settings.lm_max_samples)
        return fit_lm(network, train, validation, lm, on_epoch, lend)
    return _fit_mlp_gradient(network, data, run_settings, method, on_epoch)


def predict_scaled(network: MLP | GRUNet, x: torch.Tensor) -> np.ndarray:
    """Scaled output (n,) of the network over the whole record, run sequentially from rest."""
    network.eval()
    with torch.no_grad():
        if isinstance(network, GRUNet):
            return network(x.unsqueeze(0))[0, :, 0].numpy()
        return network(x)[:, 0].numpy()


def evaluate(network: MLP | GRUNet, data: PreparedData) -> dict[str, SplitMetrics]:
    """Metrics of every split, from one sequential run of the network over the whole record."""
    output = data.target_scaler.unscale(predict_scaled(network, data.x))
    largest = max_abs_weight(network)
    index = {name: data.splits.index(name) for name, _ in data.splits.items()}
    return {name: split_metrics(output[i], data.target[i], data.target_scaler, largest) for name, i in index.items()}


@dataclass
class Search:
    """Every run of a hidden-size search: each size's best restart (`trials`), the size chosen, and the runs in the
    order to fall back on (`ranked`: network, history, hidden size): the chosen network, then the others by their
    validation error."""

    trials: list[SizeTrial]
    hidden: int
    ranked: list[tuple[MLP | GRUNet, FitHistory, int]]


def fit_best(
    data: PreparedData, architecture: Architecture, settings: TrainSettings, progress: Progress | None = None
) -> tuple[MLP | GRUNet, FitHistory, list[SizeTrial], int]:
    """Every hidden size x every restart; returns the chosen network, its history, each size's trial and the size."""
    found = search(data, architecture, settings, progress)
    network, history, hidden = found.ranked[0]
    return network, history, found.trials, hidden


def search(
    data: PreparedData, architecture: Architecture, settings: TrainSettings, progress: Progress | None = None
) -> Search:
    """Every hidden size x every restart, the chosen size the smallest within `hidden_tolerance` of the best.

    The runs are independent (each from its own seeded initialisation), so they go side by side on up to one thread
    per core: numpy's BLAS and element-wise loops and torch's operations release the GIL. The result does not depend
    on how many run at once, nor on their order: the largest networks (the longest runs) start first, so no core ends
    the search alone with one, and a core left without a run to start lends itself to the runs still going
    (`SpareCores`), which gives the same numbers as running alone.
    """
    runs = [(hidden, restart) for hidden in architecture.hidden for restart in range(settings.restarts)]
    seeds = [restart_seed(settings.seed, hidden, restart) for hidden, restart in runs]
    networks = [new_network(architecture.kind, data.x.shape[1], h, seed) for (h, _), seed in zip(runs, seeds)]
    labels = [f"{architecture.kind} hidden {h}, restart {r + 1}/{settings.restarts}" for h, r in runs]
    tracker = _RunsProgress(labels, progress)
    with (
        _torch_threads(TRAINING_THREADS),
        threadpool_limits(limits=1, user_api="blas"),
        SpareCores(usable_cores()) as spare,
    ):
        with ThreadPoolExecutor(max_workers=parallel_fits(len(runs)), thread_name_prefix="nnfmu-fit") as pool:
            longest_first = sorted(range(len(runs)), key=lambda i: -runs[i][0])

            def fit(i: int) -> FitHistory:
                with spare.occupied():
                    return fit_network(networks[i], data, settings, seeds[i], tracker.on_epoch(i), lend=spare.lend)

            submitted = {i: pool.submit(tracker.run, i, fit, i) for i in longest_first}
            futures = [submitted[i] for i in range(len(runs))]
            try:
                for future in as_completed(futures):
                    future.result()  # the first run to fail ends the search
            except BaseException:
                tracker.abort()
                pool.shutdown(cancel_futures=True)
                raise
    histories = [future.result() for future in futures]
    trials: list[SizeTrial] = []
    best_run: dict[int, int] = {}  # hidden size -> its best restart's run
    for hidden in architecture.hidden:
        mine = [i for i, (h, _) in enumerate(runs) if h == hidden]
        best = min(mine, key=lambda i: histories[i].best_validation_loss)  # the first restart on a tie
        trials.append(SizeTrial(hidden, histories[best].best_validation_loss, runs[best][1]))
        best_run[hidden] = best
    lowest = min(t.validation_mse for t in trials)
    chosen = next(t.hidden for t in trials if t.validation_mse <= lowest * (1.0 + settings.hidden_tolerance))
    first = best_run[chosen]
    others = sorted((i for i in range(len(runs)) if i != first), key=lambda i: histories[i].best_validation_loss)
    ranked = [(networks[i], histories[i], runs[i][0]) for i in (first, *others)]
    return Search(trials=trials, hidden=chosen, ranked=ranked)


def parallel_fits(runs: int) -> int:
    """Training runs at once: one per core this process may use, at most `runs`."""
    return max(1, min(runs, usable_cores()))


class _RunsProgress:
    """The share done of runs going side by side, reported as one fraction under a lock; `abort` makes every run
    stop at its next epoch (a run that failed or was interrupted ends the search)."""

    def __init__(self, labels: list[str], progress: Progress | None) -> None:
        self._labels = labels
        self._progress = progress
        self._done = [0.0] * len(labels)
        self._lock = threading.Lock()
        self._aborted = threading.Event()

    def on_epoch(self, run: int) -> Callable[[int, int], None]:
        def report(epoch: int, total: int) -> None:
            if self._aborted.is_set():
                raise KeyboardInterrupt("training stopped: another run of the search failed or was interrupted")
            self._report(run, epoch / total)

        return report

    def run(self, run: int, fit: Callable[..., FitHistory], *args: object) -> FitHistory:
        """`fit(*args)`, then run number `run` reported done."""
        history = fit(*args)
        self._report(run, 1.0)
        return history

    def _report(self, run: int, done: float) -> None:
        if self._progress is not None:
            with self._lock:
                self._done[run] = done
                self._progress(self._labels[run], sum(self._done) / len(self._done))

    def abort(self) -> None:
        self._aborted.set()


@contextmanager
def _torch_threads(count: int) -> Iterator[None]:
    """torch's intra-op thread count set to `count` inside, restored after."""
    before = torch.get_num_threads()
    torch.set_num_threads(count)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def idle_stops(spec: FeatureSpec, data: PreparedData) -> list[tuple[Stop, float]]:
    """The spec's stop operators whose play moves on fewer than MIN_STOP_SLIP of the training samples, each with the
    share it moves on (its output sits at ±radius while the play is dragged)."""
    rows = data.splits.index("train")
    names = spec.feature_names
    idle = []
    for feature in spec.derived:
        if isinstance(feature, Stop):
            output = data.features[rows, names.index(feature.name)]
            share = float(np.mean(np.abs(output) >= feature.radius * (1.0 - 1e-9)))
            if share < MIN_STOP_SLIP:
                idle.append((feature, share))
    return idle


# Why a trained model is refused (one line per reason; empty: accepted), e.g. a bushing network giving energy back.
Acceptance = Callable[[TrainedModel], list[str]]


def train_model(
    measurement: Measurement,
    spec: FeatureSpec,
    architecture: Architecture = Architecture(),
    settings: TrainSettings = TrainSettings(),
    progress: Progress | None = None,
    accept: Acceptance | None = None,
) -> TrainResult:
    """Train a network predicting `spec.output` from `spec`'s features of `measurement` (its inputs low-passed at
    `settings.input_cutoff`), leaving out stop operators the record hardly slips (`idle_stops`); metrics on every
    split. With `accept`, a chosen network it refuses gives way to the search's next best it accepts (the notes say
    which and why); when it accepts none, the chosen one is kept with the refusals among its warnings."""
    inputs = lowpass_channels(measurement, spec.channels, settings.input_cutoff)
    data = prepare_data(inputs, spec, settings.splits)
    idle = idle_stops(spec, data)
    notes = [
        f"{stop.name} left out: the record's training part moves its play on {share:.1%} of its samples (under "
        f"{MIN_STOP_SLIP:.0%}), so it would only copy {stop.channel} less its first value and tie the network's "
        "static force to where the record starts"
        for stop, share in idle
    ]
    if idle:
        left_out = {stop.name for stop, _ in idle}
        spec = replace(spec, derived=tuple(d for d in spec.derived if d.name not in left_out))
        data = prepare_data(inputs, spec, settings.splits)
    found = search(data, architecture, settings, progress)
    chosen = _trained(measurement, spec, architecture, settings, data, found, *found.ranked[0])
    if accept is not None and (refused := accept(chosen.model)):
        for network, history, hidden in found.ranked[1:]:
            candidate = _trained(measurement, spec, architecture, settings, data, found, network, history, hidden)
            if not accept(candidate.model):
                notes.append(
                    f"the search's choice (hidden {found.hidden}, validation MSE "
                    f"{chosen.history.best_validation_loss:.3g}) was refused: {refused[0]}; kept the best network "
                    f"that passes (hidden {hidden}, validation MSE {history.best_validation_loss:.3g})"
                )
                candidate.notes = notes
                return candidate
        notes.append(f"none of the search's {len(found.ranked)} networks passes: {refused[0]}; kept its choice")
        chosen.warnings.extend(refused)
    chosen.notes = notes
    return chosen


def _trained(
    measurement: Measurement,
    spec: FeatureSpec,
    architecture: Architecture,
    settings: TrainSettings,
    data: PreparedData,
    found: Search,
    network: MLP | GRUNet,
    history: FitHistory,
    hidden: int,
) -> TrainResult:
    """One network of the search as a trained model with its metrics on every split and its warnings."""
    metrics = evaluate(network, data)
    train_part = data.splits.index("train")
    warnings = [w for w in [network_warning(network, data.x, data.y)] if w]
    n_in = data.x.shape[1]
    model = trained_model(
        spec,
        network,
        data.feature_scaler,
        data.target_scaler,
        measurement,
        train_part,
        measurement.sample_period,
        {name: m.as_dict() for name, m in metrics.items()},
        {
            **settings.as_dict(),
            "kind": architecture.kind,
            "hidden": hidden,
            "hidden_candidates": list(architecture.hidden),
            "optimizer_used": _resolve_optimizer(architecture.kind, n_in, hidden, settings.optimizer),
            "validation_mse_by_hidden": {str(t.hidden): t.validation_mse for t in found.trials},
            "best_epoch": history.best_epoch,
            "epochs_run": len(history.train_loss) - 1,
            "stop_reason": history.stop_reason,
            "samples": {name: data.splits.size(name) for name, _ in data.splits.items()},
            "source": measurement.source,
        },
    )
    return TrainResult(model=model, splits=data.splits, trials=found.trials, history=history, warnings=warnings)
