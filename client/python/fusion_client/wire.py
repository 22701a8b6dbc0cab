"""ctypes mirrors of fusiond's wire types (crate ``fusion-shared``), and its constants.

Generated from the Rust declarations by
``FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs``: do not edit.
Same fields, same layout, same versioned type names as the Rust types, so that
iceoryx2 opens fusiond's services with them. ``tests/check_layout.py`` checks
every size, offset and type name against the Rust build.
"""

import ctypes

MAX_STATE = 22
MAX_COV = 21
MAX_COV_LEN = MAX_COV * MAX_COV
MAX_SENSORS = 16

#: Sample kind codes (``SampleHeader.kind``), and their service names.
KIND_IMU = 1
KIND_POSITION = 2
KIND_VELOCITY = 3
KIND_GEODETIC = 4
KIND_ODOMETRY = 5
KIND_HEADING = 6
KIND_MAGNETOMETER = 7
KIND_TWIST = 8
KIND_BAROMETER = 9
KIND_POSE = 10
KIND_ATTITUDE = 11
#: Kind codes in use: ``1..=KIND_COUNT``.
KIND_COUNT = 11
KIND_NAMES = {
    1: "imu",
    2: "position",
    3: "velocity",
    4: "geodetic",
    5: "odometry",
    6: "heading",
    7: "magnetometer",
    8: "twist",
    9: "barometer",
    10: "pose",
    11: "attitude",
}
#: ``StateSnapshot.input_kind`` of a snapshot sent because the health changed.
INPUT_NONE = 0

HEALTH_NAMES = {
    0: "initialising",
    1: "ok",
    2: "degraded",
}
#: ``GeodeticSample.fix_type`` codes and their names.
FIX_UNKNOWN = 0
FIX_NONE = 1
FIX_2D = 2
FIX_3D = 3
FIX_DGNSS = 4
FIX_RTK_FLOAT = 5
FIX_RTK_FIXED = 6
FIX_NAMES = {
    0: "unknown",
    1: "none",
    2: "2d",
    3: "3d",
    4: "dgnss",
    5: "rtk_float",
    6: "rtk_fixed",
}
MODEL_NAMES = {
    1: "linear",
    2: "ins",
}
#: Each model's own state length and covariance side (before auxiliary states).
MODEL_DIMS = {1: [6, 6], 2: [16, 15]}
#: ``StateSnapshot.aux_states`` bits: auxiliary states after the model's own, in bit order.
AUX_ODOMETRY_SCALE = 1
AUX_BARO_BIAS = 2
AUX_POSE_FRAME = 60
#: The bits of the auxiliary states each sample kind brings (0: none).
AUX_KIND_BITS = {
    KIND_IMU: 0,
    KIND_POSITION: 0,
    KIND_VELOCITY: 0,
    KIND_GEODETIC: 0,
    KIND_ODOMETRY: 0,
    KIND_HEADING: 0,
    KIND_MAGNETOMETER: 0,
    KIND_TWIST: 0,
    KIND_BAROMETER: 1986,
    KIND_POSE: 60,
    KIND_ATTITUDE: 0,
}
AUX_NAMES = {
    1: "odometry_scale",
    2: "baro_bias_m",
    4: "pose_frame_yaw_rad",
    8: "pose_frame_east_m",
    16: "pose_frame_north_m",
    32: "pose_frame_up_m",
    64: "baro_bias_2_m",
    128: "baro_bias_3_m",
    256: "baro_bias_4_m",
    512: "baro_bias_5_m",
    1024: "baro_bias_6_m",
}
#: Why a sample was refused in validation: the index of ``StateSnapshot.rejections``
#: and ``SensorCounters.last_rejection`` (entry 0 unused).
MAX_REJECTIONS = 16
REJECTION_NON_FINITE = 1
REJECTION_COVARIANCE_NOT_SYMMETRIC = 2
REJECTION_COVARIANCE_NOT_POSITIVE_DEFINITE = 3
REJECTION_FUTURE_TIMESTAMP = 4
REJECTION_PAST_TIMESTAMP = 5
REJECTION_TIME_JUMP = 6
REJECTION_TOO_MANY_SENSORS = 7
REJECTION_OUT_OF_RANGE = 8
REJECTION_VARIANCE_NOT_POSITIVE = 9
REJECTION_WRONG_KIND = 10
REJECTION_TIME_STEP_BACK = 11
REJECTION_NAMES = {
    1: "non-finite value",
    2: "covariance not symmetric",
    3: "covariance not positive definite",
    4: "timestamp in the future",
    5: "timestamp too far in the past",
    6: "timestamp jumps too far ahead of the others",
    7: "too many sensors",
    8: "beyond the sensor range",
    9: "variance not positive",
    10: "header kind does not match the payload",
    11: "timestamp steps too far back behind the others",
}


class _Wire(ctypes.Structure):
    """A wire type: its iceoryx2 type name is ``TYPE_NAME``."""

    TYPE_NAME = ""

    @classmethod
    def type_name(cls) -> str:
        return cls.TYPE_NAME


class SampleHeader(_Wire):
    """What every sample starts with (``fusion.SampleHeader.v2``)."""

    TYPE_NAME = "fusion.SampleHeader.v2"
    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("sent_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("sensor", ctypes.c_uint32),
        ("kind", ctypes.c_uint32),
    ]


class _Sample(_Wire):
    KIND = 0


class ImuSample(_Sample):
    """Specific force (``ins``) or world acceleration (``linear``), m/s²; angular rate, rad/s
    (``fusion.ImuSample.v2``)."""

    TYPE_NAME = "fusion.ImuSample.v2"
    KIND = KIND_IMU
    _fields_ = [
        ("header", SampleHeader),
        ("accel_mps2", ctypes.c_double * 3),
        ("gyro_radps", ctypes.c_double * 3),
    ]


class PositionSample(_Sample):
    """A position fix, m ENU, with its covariance (m², row-major 3×3) (``fusion.PositionSample.v2``)."""

    TYPE_NAME = "fusion.PositionSample.v2"
    KIND = KIND_POSITION
    _fields_ = [
        ("header", SampleHeader),
        ("pos_m", ctypes.c_double * 3),
        ("cov_m2", ctypes.c_double * 9),
    ]


class VelocitySample(_Sample):
    """A velocity, m/s ENU, with its covariance (m²/s², row-major 3×3) (``fusion.VelocitySample.v2``)."""

    TYPE_NAME = "fusion.VelocitySample.v2"
    KIND = KIND_VELOCITY
    _fields_ = [
        ("header", SampleHeader),
        ("vel_mps", ctypes.c_double * 3),
        ("cov_m2ps2", ctypes.c_double * 9),
    ]


class GeodeticSample(_Sample):
    """A GNSS fix: WGS-84 latitude, longitude (deg), ellipsoidal height (m); ENU covariance m²; the
    receiver's fix type (``FIX_*``), satellites used, HDOP and VDOP (0: not reported)
    (``fusion.GeodeticSample.v3``)."""

    TYPE_NAME = "fusion.GeodeticSample.v3"
    KIND = KIND_GEODETIC
    _fields_ = [
        ("header", SampleHeader),
        ("lat_deg", ctypes.c_double),
        ("lon_deg", ctypes.c_double),
        ("height_m", ctypes.c_double),
        ("cov_enu_m2", ctypes.c_double * 9),
        ("fix_type", ctypes.c_uint32),
        ("satellites", ctypes.c_int32),
        ("hdop", ctypes.c_double),
        ("vdop", ctypes.c_double),
    ]


class OdometrySample(_Sample):
    """Forward speed from wheel odometry, m/s, with its variance (``fusion.OdometrySample.v2``)."""

    TYPE_NAME = "fusion.OdometrySample.v2"
    KIND = KIND_ODOMETRY
    _fields_ = [
        ("header", SampleHeader),
        ("speed_mps", ctypes.c_double),
        ("var_m2ps2", ctypes.c_double),
    ]


class HeadingSample(_Sample):
    """Yaw, rad ENU (from east, counter-clockwise), with its variance (``fusion.HeadingSample.v2``)."""

    TYPE_NAME = "fusion.HeadingSample.v2"
    KIND = KIND_HEADING
    _fields_ = [
        ("header", SampleHeader),
        ("yaw_rad", ctypes.c_double),
        ("var_rad2", ctypes.c_double),
    ]


class MagnetometerSample(_Sample):
    """A magnetometer's field, µT in the sensor's axes (calibrated), with its covariance (µT², row-major
    3×3) (``fusion.MagnetometerSample.v2``)."""

    TYPE_NAME = "fusion.MagnetometerSample.v2"
    KIND = KIND_MAGNETOMETER
    _fields_ = [
        ("header", SampleHeader),
        ("field_ut", ctypes.c_double * 3),
        ("cov_ut2", ctypes.c_double * 9),
    ]


class TwistSample(_Sample):
    """Linear (m/s) and angular (rad/s) velocity in the sensor's axes, with their covariance (row-major
    6×6, linear then angular): visual or lidar odometry (``fusion.TwistSample.v2``)."""

    TYPE_NAME = "fusion.TwistSample.v2"
    KIND = KIND_TWIST
    _fields_ = [
        ("header", SampleHeader),
        ("linear_mps", ctypes.c_double * 3),
        ("angular_radps", ctypes.c_double * 3),
        ("cov", ctypes.c_double * 36),
    ]


class BarometerSample(_Sample):
    """Static air pressure, Pa, with its variance (Pa²) (``fusion.BarometerSample.v1``)."""

    TYPE_NAME = "fusion.BarometerSample.v1"
    KIND = KIND_BAROMETER
    _fields_ = [
        ("header", SampleHeader),
        ("pressure_pa", ctypes.c_double),
        ("var_pa2", ctypes.c_double),
    ]


class PoseSample(_Sample):
    """A localiser's pose in its map frame: position (m), unit quaternion ``[w, x, y, z]`` of the sensor's
    axes into the map, covariance (row-major 6×6, position then attitude about the sensor's axes) and
    the localiser's reset counter (``fusion.PoseSample.v1``)."""

    TYPE_NAME = "fusion.PoseSample.v1"
    KIND = KIND_POSE
    _fields_ = [
        ("header", SampleHeader),
        ("position_m", ctypes.c_double * 3),
        ("orientation_wxyz", ctypes.c_double * 4),
        ("cov", ctypes.c_double * 36),
        ("reset_counter", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]


class AttitudeSample(_Sample):
    """An AHRS's orientation: unit quaternion ``[w, x, y, z]`` of the sensor's axes into the world frame
    (ENU), with the covariance of its error about the sensor's axes (rad², row-major 3×3)
    (``fusion.AttitudeSample.v1``)."""

    TYPE_NAME = "fusion.AttitudeSample.v1"
    KIND = KIND_ATTITUDE
    _fields_ = [
        ("header", SampleHeader),
        ("orientation_wxyz", ctypes.c_double * 4),
        ("cov_rad2", ctypes.c_double * 9),
    ]


SAMPLE_TYPES = (
    ImuSample,
    PositionSample,
    VelocitySample,
    GeodeticSample,
    OdometrySample,
    HeadingSample,
    MagnetometerSample,
    TwistSample,
    BarometerSample,
    PoseSample,
    AttitudeSample,
)


class Counters(_Wire):
    """What became of a sensor's samples (``fusion.Counters.v3``)."""

    TYPE_NAME = "fusion.Counters.v3"
    _fields_ = [
        ("received", ctypes.c_uint64),
        ("processed", ctypes.c_uint64),
        ("fused", ctypes.c_uint64),
        ("gated", ctypes.c_uint64),
        ("refused", ctypes.c_uint64),
        ("late", ctypes.c_uint64),
        ("too_late", ctypes.c_uint64),
        ("duplicate", ctypes.c_uint64),
        ("invalid", ctypes.c_uint64),
        ("lost", ctypes.c_uint64),
        ("rate_limited", ctypes.c_uint64),
        ("restarts", ctypes.c_uint64),
    ]


class SensorCounters(_Wire):
    """One sensor's row of the snapshot (``fusion.SensorCounters.v4``)."""

    TYPE_NAME = "fusion.SensorCounters.v4"
    _fields_ = [
        ("kind", ctypes.c_uint32),
        ("sensor", ctypes.c_uint32),
        ("counts", Counters),
        ("last_nis", ctypes.c_double),
        ("last_t_ns", ctypes.c_uint64),
        ("last_arrival_ns", ctypes.c_uint64),
        ("rejection_reasons", ctypes.c_uint32),
        ("last_rejection", ctypes.c_uint32),
    ]


class StateSnapshot(_Wire):
    """The fusion state after one processed sample (``fusion.StateSnapshot.v12``)."""

    TYPE_NAME = "fusion.StateSnapshot.v12"
    _fields_ = [
        ("seq", ctypes.c_uint64),
        ("publish_ns", ctypes.c_uint64),
        ("t_ns", ctypes.c_uint64),
        ("sample_seq", ctypes.c_uint64),
        ("sample_sensor", ctypes.c_uint32),
        ("sample_kind", ctypes.c_uint32),
        ("outcome", ctypes.c_uint32),
        ("model", ctypes.c_uint32),
        ("nis", ctypes.c_double),
        ("input_t_ns", ctypes.c_uint64),
        ("input_sent_ns", ctypes.c_uint64),
        ("input_received_ns", ctypes.c_uint64),
        ("input_seq", ctypes.c_uint64),
        ("input_sensor", ctypes.c_uint32),
        ("input_kind", ctypes.c_uint32),
        ("input_replayed", ctypes.c_uint32),
        ("health", ctypes.c_uint32),
        ("health_reasons", ctypes.c_uint32),
        ("state_len", ctypes.c_uint32),
        ("cov_dim", ctypes.c_uint32),
        ("sensor_count", ctypes.c_uint32),
        ("x", ctypes.c_double * MAX_STATE),
        ("cov", ctypes.c_double * MAX_COV_LEN),
        ("sensors", SensorCounters * MAX_SENSORS),
        ("rewinds", ctypes.c_uint64),
        ("replayed", ctypes.c_uint64),
        ("unknown_sensor", ctypes.c_uint64),
        ("datum_lat_deg", ctypes.c_double),
        ("datum_lon_deg", ctypes.c_double),
        ("datum_height_m", ctypes.c_double),
        ("datum_set", ctypes.c_uint32),
        ("stale_sensors", ctypes.c_uint32),
        ("nis_sensors", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("reinitialisations", ctypes.c_uint64),
        ("readers_refused", ctypes.c_uint64),
        ("pending_steps", ctypes.c_uint64),
        ("pending_since_t_ns", ctypes.c_uint64),
        ("background_steps", ctypes.c_uint64),
        ("standstill_updates", ctypes.c_uint64),
        ("standing", ctypes.c_uint32),
        ("aux_states", ctypes.c_uint32),
        ("velocity_offset_ns", ctypes.c_double),
        ("velocity_offset_std_ns", ctypes.c_double),
        ("velocity_offset_samples", ctypes.c_uint64),
        ("rejections", ctypes.c_uint64 * MAX_REJECTIONS),
    ]


#: Every mirror, for the layout check.
ALL_TYPES = (SampleHeader,) + SAMPLE_TYPES + (Counters, SensorCounters, StateSnapshot)
