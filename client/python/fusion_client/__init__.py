"""fusion_client: publish samples to fusiond and read its state from Python.

Built on iceoryx2's own Python package (``iceoryx2`` 0.10, the version of the
Rust crates) with ctypes mirrors of the wire types (:mod:`fusion_client.wire`)::

    import fusion_client as fc

    client = fc.Client("fusion")
    imu = client.publisher(fc.ImuSample, sensor=0)
    imu.publish(fc.ImuSample(accel_mps2=(0.1, 0.0, 0.0)), t_ns=fc.now_ns())
    state = client.state_reader()
    s = state.wait_next(timeout=1.0)
    print(s.position, s.position_std, s.health_name)  # and s.x, s.P: the raw estimate
    print(s.roll_pitch_yaw)                           # ins: rad; None for linear

Like the Rust client, a client and its ports belong to the thread that made them.
"""

import atexit
import ctypes
import math
import os
import time
import weakref

import iceoryx2 as iox2
import numpy as np

from .wire import (
    ALL_TYPES,
    AUX_BARO_BIAS,
    AUX_NAMES,
    AUX_ODOMETRY_SCALE,
    AUX_POSE_FRAME,
    HEALTH_NAMES,
    INPUT_NONE,
    KIND_NAMES,
    MAX_COV,
    MAX_STATE,
    MODEL_DIMS,
    MODEL_NAMES,
    REJECTION_NAMES,
    SAMPLE_TYPES,
    AttitudeSample,
    BarometerSample,
    Counters,
    GeodeticSample,
    HeadingSample,
    ImuSample,
    MagnetometerSample,
    OdometrySample,
    PoseSample,
    PositionSample,
    SampleHeader,
    SensorCounters,
    StateSnapshot,
    TwistSample,
    VelocitySample,
)

__all__ = [
    "ALL_TYPES", "AttitudeSample", "BarometerSample", "Client", "Counters", "DaemonNotRunning", "FusionError", "GeodeticSample", "HeadingSample",
    "ImuSample", "INPUT_NONE", "MagnetometerSample", "OdometrySample", "PoseSample", "PositionSample",
    "Publisher", "SampleHeader",
    "SensorCounters", "Snapshot", "StateReader", "StateSnapshot", "TwistSample", "VelocitySample", "now_ns",
]

#: Environment variable naming the iceoryx2 domain (as for every fusiond process).
DOMAIN_ENV = "FUSION_ICEORYX_DOMAIN"

# The service settings of `fusion_shared::service` (checked by tests/check_layout.py).
SAMPLE_BUFFER = 4096
MAX_SAMPLE_PUBLISHERS = 16
MAX_BORROWED_PER_PUBLISHER = 8
MAX_SAMPLE_SUBSCRIBERS = 4
STATE_BUFFER = 512
MAX_NODES = 32
MAX_EVENT_PORTS = 32
READER_REFUSED_EVENT = 1
MAX_NAMESPACE_LEN = 64

# Health reason bits (`fusion_shared::snapshot::health`).
_GENERAL_REASONS = ((1 << 0, "nis out of bounds"), (1 << 1, "samples lost"), (1 << 2, "re-initialised after a lock-out"))

# Index of the attitude error δθ in the ins covariance.
_ATTITUDE_ERROR = 6

# Longest sleep while waiting for a snapshot: a reader that connected after the
# last snapshot gets the latest one without an event, so waits re-check this often.
_WAIT_SLICE_S = 0.005


class FusionError(Exception):
    """A refusal of fusiond's services or of an argument, with the reason."""


class DaemonNotRunning(FusionError):
    """No fusiond has published state in the namespace."""


def now_ns() -> int:
    """Nanoseconds of CLOCK_MONOTONIC: the clock of every timestamp."""
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def _check_namespace(namespace: str) -> None:
    # The same rule as fusion_shared::service::namespace_arg: nothing path-like.
    ok = (
        0 < len(namespace) <= MAX_NAMESPACE_LEN
        and all(c.isascii() and (c.isalnum() or c in "_-.") for c in namespace)
        and (namespace[0].isalnum() or namespace[0] == "_")
        and ".." not in namespace
    )
    if not ok:
        raise ValueError(
            f"invalid namespace {namespace!r}: use 1 to {MAX_NAMESPACE_LEN} characters of A-Z a-z 0-9 _ - ., "
            'starting with a letter, digit or _ and without ".." (a namespace is part of file names)'
        )


def _config(domain):
    config = iox2.config.default()
    domain = domain if domain is not None else (os.environ.get(DOMAIN_ENV) or None)
    if domain is not None:
        ok = 0 < len(domain) <= 32 and all(c.isascii() and (c.isalnum() or c in "_-") for c in domain)
        if not ok:
            raise ValueError(f"invalid iceoryx2 domain {domain!r}: use 1 to 32 characters of A-Z a-z 0-9 _ -")
        config.global_cfg.prefix = iox2.FileName.new(f"iox2_{domain}_")
    return config


def _finite(value) -> bool:
    """Every float in a ctypes structure or array is finite."""
    if isinstance(value, ctypes.Structure):
        return all(_finite(getattr(value, name)) for name, _ in value._fields_)
    if isinstance(value, ctypes.Array):
        return all(_finite(v) for v in value)
    if isinstance(value, float):
        return math.isfinite(value)
    return True


class Client:
    """A connection to fusiond's services in one namespace (``"fusion"`` unless
    fusiond was given another), in the iceoryx2 domain ``domain`` or the one
    named by ``FUSION_ICEORYX_DOMAIN``. Works whether or not fusiond runs."""

    def __init__(self, namespace: str = "fusion", domain=None):
        _check_namespace(namespace)
        self.namespace = namespace
        try:
            self._node = (
                iox2.NodeBuilder.new()
                .name(iox2.NodeName.new(f"fusion-client-py.{namespace}"))
                .config(_config(domain))
                .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
                .create(iox2.ServiceType.Ipc)
            )
        except iox2.NodeCreationFailure as e:
            raise FusionError(f"cannot create iceoryx2 node: {e!r}") from e

    def _service_name(self, suffix: str):
        return iox2.ServiceName.new(f"{self.namespace}/{suffix}")

    def _event(self, suffix: str):
        try:
            return (
                self._node.service_builder(self._service_name(suffix))
                .event()
                .max_notifiers(MAX_EVENT_PORTS)
                .max_listeners(MAX_EVENT_PORTS)
                .max_nodes(MAX_NODES)
                .open_or_create()
            )
        except Exception as e:
            raise FusionError(f"service {self.namespace}/{suffix}: {e!r}") from e

    def publisher(self, sample_type, sensor: int = 0) -> "Publisher":
        """A publisher of sensor ``sensor``'s samples of ``sample_type``
        (:class:`ImuSample`, :class:`PositionSample`, ...) on ``<ns>/<kind>``."""
        if sample_type not in SAMPLE_TYPES:
            raise ValueError(f"not a sample type: {sample_type!r}")
        name = KIND_NAMES[sample_type.KIND]
        try:
            service = (
                self._node.service_builder(self._service_name(name))
                .publish_subscribe(sample_type)
                .enable_safe_overflow(True)
                .subscriber_max_buffer_size(SAMPLE_BUFFER)
                .subscriber_max_borrowed_samples(MAX_BORROWED_PER_PUBLISHER)
                .history_size(0)
                .max_publishers(MAX_SAMPLE_PUBLISHERS)
                .max_subscribers(MAX_SAMPLE_SUBSCRIBERS)
                .max_nodes(MAX_NODES)
                .open_or_create()
            )
            publisher = service.publisher_builder().create()
        except Exception as e:
            raise FusionError(f"service {self.namespace}/{name}: {e!r}") from e
        wake = self._event("wake").notifier_builder().create()
        return Publisher(sample_type, sensor, publisher, wake)

    def state_reader(self, buffer: int = 64) -> "StateReader":
        """A reader of ``<ns>/state`` keeping up to ``buffer`` unread snapshots.
        Raises :class:`DaemonNotRunning` when no fusiond ever started here."""
        try:
            service = self._node.service_builder(self._service_name("state")).publish_subscribe(StateSnapshot).open()
        except iox2.PublishSubscribeOpenError as e:
            if "DoesNotExist" in repr(e):
                raise DaemonNotRunning(f"fusiond is not running in namespace {self.namespace!r}") from e
            raise FusionError(f"service {self.namespace}/state: {e!r}") from e
        try:
            subscriber = service.subscriber_builder().buffer_size(max(1, min(buffer, STATE_BUFFER))).create()
        except Exception as e:
            if "ExceedsMaxSupportedSubscribers" in repr(e):
                # Tell fusiond, which counts refused readers in its snapshots.
                self._event("wake").notifier_builder().create().notify_with_custom_event_id(
                    iox2.EventId.new(READER_REFUSED_EVENT)
                )
                raise FusionError(f"all reader slots of {self.namespace}/state are taken") from e
            raise FusionError(f"service {self.namespace}/state: {e!r}") from e
        return StateReader(subscriber, self._event("state"))


#: How long a publisher keeps its samples available after the last one that
#: reached fusiond, for fusiond to connect and take them (as the Rust client's
#: ``DEFAULT_LINGER``): ``close()`` and the interpreter's exit wait for it.
LINGER_S = 0.1

#: Publishers that may still hold samples fusiond has not connected to.
_LINGERING = weakref.WeakSet()


@atexit.register
def _linger_at_exit():
    # A script that publishes and ends at once: its publishers go with the
    # interpreter, before fusiond may have connected to them.
    for p in list(_LINGERING):
        p.close()


class Publisher:
    """Publishes one sensor's samples of one kind and wakes fusiond.

    iceoryx2 hands fusiond a publisher's samples only once fusiond has
    connected to it (on its next look, after the wake-up); ``close()`` waits up
    to ``LINGER_S`` after the last sample that reached fusiond so that none is
    lost, and the interpreter's exit does the same for every open publisher."""

    def __init__(self, sample_type, sensor, publisher, wake):
        self.sample_type = sample_type
        self.sensor = sensor
        self.next_seq = 0
        self._publisher = publisher
        self._wake = wake
        self._last_delivered = None
        _LINGERING.add(self)

    def close(self, linger: float = LINGER_S) -> None:
        """Releases the publisher, first waiting until ``linger`` seconds have
        passed since its last sample that reached fusiond."""
        if self._publisher is None:
            return
        if self._last_delivered is not None:
            left = self._last_delivered + linger - time.monotonic()
            if left > 0:
                self._wake.notify()
                time.sleep(left)
        self._publisher = None
        self._wake = None
        _LINGERING.discard(self)

    def publish(self, sample, t_ns=None) -> int:
        """Publishes ``sample`` as this sensor's next sample: stamps its header's
        sensor id, next sequence number, kind and send time (and ``t_ns`` if
        given). Raises ``ValueError`` for a NaN or infinite value, ``TypeError``
        for a sample of another kind. Returns the readers it reached (0: no
        fusiond)."""
        if not isinstance(sample, self.sample_type):
            raise TypeError(f"a {type(sample).__name__} given to a {self.sample_type.__name__} publisher")
        if t_ns is not None:
            sample.header.t_ns = t_ns
        if not _finite(sample):
            raise ValueError(f"{type(sample).__name__} with a NaN or infinite value")
        sample.header.sensor = self.sensor
        sample.header.seq = self.next_seq
        sample.header.kind = self.sample_type.KIND
        sample.header.sent_ns = now_ns()
        if self._publisher is None:
            raise FusionError("the publisher is closed")
        reached = self._publisher.send_copy(sample)
        if reached:
            self._last_delivered = time.monotonic()
        self.next_seq += 1
        self._wake.notify()
        return reached


class Snapshot:
    """A snapshot read from fusiond: the raw :class:`StateSnapshot` (``raw``),
    the estimate as numpy arrays (whole: ``x``, ``P``; by name: ``position``,
    ``roll_pitch_yaw``, ``gyro_bias_std``, ...) and the codes by name."""

    def __init__(self, raw: StateSnapshot):
        self.raw = raw

    def __getattr__(self, name):
        return getattr(self.raw, name)

    @property
    def x(self) -> np.ndarray:
        """The state vector in use (``linear``: p, v; ``ins``: p, v, q (w, x, y, z), b_a, b_g)."""
        n = min(self.raw.state_len, len(self.raw.x))
        return np.array(self.raw.x[:n], dtype=np.float64)

    @property
    def P(self) -> np.ndarray:  # noqa: N802 (the usual name of the covariance)
        """The covariance in use, ``cov_dim × cov_dim``."""
        n = min(self.raw.cov_dim, MAX_COV)
        return np.array(self.raw.cov[: n * n], dtype=np.float64).reshape(n, n)

    @property
    def health_name(self) -> str:
        return HEALTH_NAMES.get(self.raw.health, "unknown")

    @property
    def health_reason_names(self) -> list:
        reasons = self.raw.health_reasons
        names = [name for bit, name in _GENERAL_REASONS if reasons & bit]
        names += [f"{KIND_NAMES[k]} stale" for k in sorted(KIND_NAMES) if reasons & (1 << (8 + k))]
        return names

    @property
    def model_name(self) -> str:
        return MODEL_NAMES.get(self.raw.model, "unknown")

    @property
    def standing(self) -> bool:
        """Whether the vehicle was detected standing still (``[model.standstill]``:
        the attitude is held, zero-velocity and zero-rate updates are fused)."""
        return self.raw.standing != 0

    @property
    def settled(self) -> bool:
        """Whether the estimate includes every sample fusiond had received (no
        late sample's correction pending, ``pending_steps == 0``). A provisional
        snapshot lacks the effect of the sample at ``pending_since_t_ns``; a
        later one includes it."""
        return self.raw.pending_steps == 0

    @property
    def rejections(self) -> dict:
        """Samples fusiond refused in validation since it started, by reason
        (``REJECTION_NAMES``; a sensor's own in its row: ``invalid``,
        ``rejection_reasons``, ``last_rejection``): only the reasons with a count."""
        counts = self.raw.rejections
        return {name: int(counts[code]) for code, name in REJECTION_NAMES.items() if counts[code]}

    def sensor_counters(self) -> list:
        """The sensor rows in use."""
        return list(self.raw.sensors[: min(self.raw.sensor_count, len(self.raw.sensors))])

    # The estimate by name, as the Rust client's ``StateSnapshot`` accessors give
    # it (the same layout knowledge, the same formulas): each is a numpy array, or
    # ``None`` when the snapshot's model does not have it (or is not known).

    def _model_known(self) -> bool:
        return self.raw.model in MODEL_NAMES

    def _ins(self) -> bool:
        return MODEL_NAMES.get(self.raw.model) == "ins"

    def _state(self, at: int, n: int):
        if not self._model_known() or at + n > min(self.raw.state_len, MAX_STATE):
            return None
        return np.array(self.raw.x[at : at + n], dtype=np.float64)

    def _std3(self, at: int):
        n = self.raw.cov_dim
        if not self._model_known() or at + 3 > n or n > MAX_COV:
            return None
        return np.array([math.sqrt(max(self.raw.cov[(at + i) * n + at + i], 0.0)) for i in range(3)])

    @property
    def position(self):
        """Position, m, world frame (ENU about the datum): ``x[0:3]`` in every model."""
        return self._state(0, 3)

    @property
    def velocity(self):
        """Velocity, m/s, world frame (ENU): ``x[3:6]`` in every model."""
        return self._state(3, 3)

    @property
    def attitude(self):
        """Attitude as the unit quaternion ``[w, x, y, z]`` rotating the body frame
        (forward-left-up) into the world frame (ENU): ``x[6:10]``, ``ins`` only."""
        return self._state(6, 4) if self._ins() else None

    @property
    def roll_pitch_yaw(self):
        """Roll, pitch and yaw, rad, ``ins`` only: body → world is
        ``Rz(yaw) Ry(pitch) Rx(roll)`` (ZYX on ENU and forward-left-up axes); yaw is
        the forward axis's angle from east, counter-clockwise (a compass heading is
        90° − yaw)."""
        q = self.attitude
        if q is None:
            return None
        norm = math.sqrt(float(q @ q))
        if math.isnan(norm) or norm <= 0.0:
            return None
        w, x, y, z = (float(c) / norm for c in q)
        roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        pitch = math.asin(min(max(2.0 * (w * y - z * x), -1.0), 1.0))
        yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        return np.array([roll, pitch, yaw])

    @property
    def accel_bias(self):
        """Accelerometer bias, m/s², body frame: ``x[10:13]``, ``ins`` only."""
        return self._state(10, 3) if self._ins() else None

    @property
    def gyro_bias(self):
        """Gyroscope bias, rad/s, body frame: ``x[13:16]``, ``ins`` only."""
        return self._state(13, 3) if self._ins() else None

    @property
    def position_std(self):
        """Standard deviation of each position component, m."""
        return self._std3(0)

    @property
    def velocity_std(self):
        """Standard deviation of each velocity component, m/s."""
        return self._std3(3)

    @property
    def attitude_std(self):
        """Standard deviation of the attitude error about each body axis (forward,
        left, up), rad: the error state δθ, ``ins`` only."""
        return self._std3(_ATTITUDE_ERROR) if self._ins() else None

    @property
    def roll_pitch_yaw_std(self):
        """Standard deviation of roll, pitch and yaw, rad, ``ins`` only: the
        attitude error covariance mapped through the Euler-angle rates,
        ``E Σθ Eᵀ`` with ``E = [[1, sφ tθ, cφ tθ], [0, cφ, −sφ], [0, sφ/cθ, cφ/cθ]]``
        (φ roll, θ pitch). Infinite at pitch ±90°."""
        rpy = self.roll_pitch_yaw
        if rpy is None or self.attitude_std is None:
            return None
        roll, pitch = float(rpy[0]), float(rpy[1])
        n, a = self.raw.cov_dim, _ATTITUDE_ERROR
        sr, cr, tp, cp = math.sin(roll), math.cos(roll), math.tan(pitch), math.cos(pitch)
        e = [[1.0, sr * tp, cr * tp], [0.0, cr, -sr], [0.0, sr / cp, cr / cp]]
        out = []
        for r in range(3):
            var = 0.0
            for i in range(3):
                for j in range(3):
                    var += e[r][i] * self.raw.cov[(a + i) * n + a + j] * e[r][j]
            out.append(math.sqrt(max(var, 0.0)))
        return np.array(out)

    @property
    def accel_bias_std(self):
        """Standard deviation of each accelerometer bias component, m/s², ``ins`` only."""
        return self._std3(9) if self._ins() else None

    @property
    def gyro_bias_std(self):
        """Standard deviation of each gyroscope bias component, rad/s, ``ins`` only."""
        return self._std3(12) if self._ins() else None

    def _aux(self, bit: int):
        """Value and standard deviation of auxiliary state ``bit`` (after the
        model's own states, in bit order), or ``None``."""
        raw = self.raw
        dims = MODEL_DIMS.get(raw.model)
        known = sum(b for b in AUX_NAMES)
        extra = bin(raw.aux_states & known).count("1")
        if (
            dims is None
            or not raw.aux_states & bit
            or bin(raw.aux_states).count("1") != extra
            or raw.state_len != dims[0] + extra
            or raw.cov_dim != dims[1] + extra
            or raw.state_len > MAX_STATE
            or raw.cov_dim > MAX_COV
        ):
            return None
        rank = bin(raw.aux_states & (bit - 1)).count("1")
        i, c, n = dims[0] + rank, dims[1] + rank, raw.cov_dim
        return raw.x[i], math.sqrt(max(raw.cov[c * n + c], 0.0))

    @property
    def odometry_scale(self):
        """The odometry scale factor ``k`` (odometry speed = ``k`` × true speed) and
        its standard deviation, ``ins`` with ``[model.odometry_scale]`` only."""
        v = self._aux(AUX_ODOMETRY_SCALE)
        return None if v is None else np.array(v, dtype=np.float64)

    @property
    def baro_bias(self):
        """The barometer's bias (pressure altitude minus height, m) and its standard deviation, ``ins``
        with a barometer only."""
        v = self._aux(AUX_BARO_BIAS)
        return None if v is None else np.array(v, dtype=np.float64)

    @property
    def pose_frame(self):
        """A pose sensor's estimated map frame: yaw (rad), origin east, north, up (m), then their four
        standard deviations (8 values), ``ins`` with a pose sensor whose frame is estimated only."""
        rows = [self._aux(bit) for bit in sorted(b for b in AUX_NAMES if b & AUX_POSE_FRAME)]
        if any(r is None for r in rows):
            return None
        return np.array([r[0] for r in rows] + [r[1] for r in rows], dtype=np.float64)


class StateReader:
    """Reads fusiond's snapshots in publication order."""

    def __init__(self, subscriber, event):
        self._subscriber = subscriber
        self._event = event
        self._listener = None
        self._last = None

    def _receive(self):
        sample = self._subscriber.receive()
        if sample is None:
            return None
        # Copied out at once: the slot goes back to fusiond.
        snapshot = Snapshot(StateSnapshot.from_buffer_copy(sample.payload().contents))
        sample.delete()
        self._last = snapshot
        return snapshot

    def try_next(self):
        """The next unread snapshot, or ``None`` right away."""
        return self._receive()

    def latest(self):
        """The newest snapshot, skipping older unread ones; the last one again if
        nothing new came; ``None`` if none ever did."""
        while self._receive() is not None:
            pass
        return self._last

    def wait_next(self, timeout: float = 1.0):
        """The next unread snapshot, sleeping on fusiond's state event until one
        arrives or ``timeout`` seconds pass (``None``)."""
        deadline = time.monotonic() + timeout
        while True:
            snapshot = self._receive()
            if snapshot is not None:
                return snapshot
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            if self._listener is None:
                self._listener = self._event.listener_builder().create()
            # Whole microseconds, at least one: iceoryx2 takes 0 as "no timeout".
            wait_us = max(1, math.ceil(min(left, _WAIT_SLICE_S) * 1e6))
            self._listener.timed_wait(iox2.Duration.from_micros(wait_us))
