"""The bag-side transport, and the message layouts both transports share (no ROS imports).

This is one of the two modules that know topic names and which message field holds what (the
other is :mod:`gear_phm.nodes.transport`, the live side, which takes its names from here).
The pure logic returns domain records (:class:`~gear_phm.estimation.FrictionEstimate`,
:class:`~gear_phm.prognostics.HealthState`, :class:`~gear_phm.status.StatusOut`); this
module maps them to and from layout records (:class:`Vector3Out`, :class:`DiagnosticsOut`),
which the live node turns into rclpy messages and ``gear_phm.bagio`` into bag records. The
field layouts are tables (:data:`ESTIMATE_LAYOUT`, :data:`HEALTH_LAYOUT`, :data:`STATUS_KEYS`)
that encoding and decoding both read. JointState input is decoded by :mod:`gear_phm.codec`.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
import functools
import math
import operator
import struct
from typing import Any, TYPE_CHECKING

import numpy as np

from gear_phm.codec import common_stride
from gear_phm.estimation.records import FrictionEstimate
from gear_phm.status import format_values, StatusOut

if TYPE_CHECKING:
    from gear_phm.prognostics.assessor import HealthState

# --- topic names (relative, so namespaces and remaps apply) ---------------------------------
JOINT_STATES = 'joint_states'
TRUTH_FRICTION = 'gear_phm/truth/friction'
TRUTH_EFFICIENCY = 'gear_phm/truth/efficiency'
TRUTH_NO_LOAD = 'gear_phm/truth/no_load'
TRUTH_OIL = 'gear_phm/truth/oil'
OIL_TEMPERATURE = 'oil_temperature'
FRICTION = 'gear_phm/friction'
FRICTION_COVARIANCE = 'gear_phm/friction_covariance'
EFFICIENCY = 'gear_phm/efficiency'
INNOVATION = 'gear_phm/innovation'
COUNTS = 'gear_phm/counts'
OPERATING_TIME = 'gear_phm/operating_time'
DIRECTION_OFFSET = 'gear_phm/direction_offset'
SAMPLE_LOSS = 'gear_phm/sample_loss'
NO_LOAD = 'gear_phm/no_load'
HEALTH_RUL = 'gear_phm/health/rul'
HEALTH_EFFICIENCY = 'gear_phm/health/efficiency'
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'


def drive_topic(drive: str, topic: str) -> str:
    """Return one drive's topic of many.

    ``gear_phm/friction`` -> ``gear_phm/<drive>/friction``, ``gear_phm/truth/friction`` ->
    ``gear_phm/<drive>/truth/friction``.
    """
    head, slash, tail = topic.partition('/')
    return f'{head}/{drive}/{tail}' if slash else f'{drive}/{topic}'


JOINT_STATE_TYPE = 'sensor_msgs/msg/JointState'
VECTOR3_STAMPED_TYPE = 'geometry_msgs/msg/Vector3Stamped'
DIAGNOSTIC_ARRAY_TYPE = 'diagnostic_msgs/msg/DiagnosticArray'
CLOCK_TYPE = 'rosgraph_msgs/msg/Clock'
TEMPERATURE_TYPE = 'sensor_msgs/msg/Temperature'

# --- which field of which Vector3Stamped holds what -------------------------------------------
#: A layout: topics in publishing order, each with the record attributes its x, y, z hold.
Layout = tuple[tuple[str, tuple[str, str, str]], ...]

#: The estimator's outputs, all geometry_msgs/Vector3Stamped with the same stamp per update,
#: and the :class:`~gear_phm.estimation.FrictionEstimate` attributes they hold. The one
#: statement of this layout: publishers (:func:`estimate_outputs`), the bag writer
#: (:func:`vector3_columns`) and readers (:func:`estimate_from_vectors`) follow it.
ESTIMATE_LAYOUT: Layout = (
    (FRICTION, ('u', 'rate', 'u_sigma')),
    (FRICTION_COVARIANCE, ('p_uu', 'p_ur', 'p_rr')),
    (EFFICIENCY, ('eta_opposing', 'eta_aiding', 'measured_efficiency')),
    (INNOVATION, ('innovation', 'innovation_variance', 'nis')),
    (COUNTS, ('samples_used', 'samples_rejected', 'power_flow')),
    (DIRECTION_OFFSET, ('direction_offset', 'measurement_direction', 'measurement_bias')),
    (OPERATING_TIME, ('operating_time', 'measurement', 'measurement_variance')),
)
#: With the no-load model (``no_load_model``) the estimator also publishes, in the same group
#: and after the others: x = no-load torque at the motor at the reference speed [N m], y =
#: its std dev [N m], z = total efficiency at the rated point [-] (NaN without one).
NO_LOAD_LAYOUT: Layout = (
    (NO_LOAD, ('no_load_torque', 'no_load_sigma', 'total_efficiency')),
)


def estimate_layout(no_load: bool) -> Layout:
    """Return the estimator's output layout.

    :data:`ESTIMATE_LAYOUT`, with ``no_load`` also :data:`NO_LOAD_LAYOUT`.
    """
    return ESTIMATE_LAYOUT + NO_LOAD_LAYOUT if no_load else ESTIMATE_LAYOUT


#: The diagnostics node's outputs and the :class:`~gear_phm.prognostics.HealthState`
#: attributes they hold (RUL [s] of elapsed time; level 0 OK .. 3 STALE).
HEALTH_LAYOUT: Layout = (
    (HEALTH_RUL, ('rul.median', 'rul.p5', 'rul.p95')),
    (HEALTH_EFFICIENCY, ('eta_opposing', 'eta_aiding', 'level')),
)

#: The simulator's truth, geometry_msgs/Vector3Stamped, and the
#: :class:`~gear_phm.simulation.SimulationResult` arrays its x, y, z hold ('': 0). The first
#: two always; the no-load and oil truth when a real-gearbox effect of the plant is on
#: (``SimulationConfig.extended_truth``): no_load_torque [N m] (T_0 sign(w_m) + c_v w_m at
#: the speed and oil temperature), no_load_coulomb T_0 [N m], no_load_viscous c_v
#: [N m s/rad]; oil_temperature [degC], drag_factor [-] (drag over the warm drag),
#: load_scale [-] (the air load over the nominal one).
TRUTH_LAYOUT: Layout = (
    (TRUTH_FRICTION, ('u', 'friction', '')),
    (TRUTH_EFFICIENCY, ('eta_opposing', 'eta_aiding', '')),
    (TRUTH_NO_LOAD, ('no_load_torque', 'no_load_coulomb', 'no_load_viscous')),
    (TRUTH_OIL, ('oil_temperature', 'drag_factor', 'load_scale')),
)
#: The truth topics written for every run (the rest of TRUTH_LAYOUT: extended truth only).
BASIC_TRUTH_TOPICS = (TRUTH_FRICTION, TRUTH_EFFICIENCY)
#: sensor_msgs/Temperature on OIL_TEMPERATURE (``publish_temperature``): ``temperature`` is
#: the true oil temperature [degC], ``variance`` 0.
TEMPERATURE_FIELDS = ('oil_temperature', '')

#: Estimator outputs, in publishing order.
ESTIMATOR_TOPICS = tuple(topic for topic, _ in ESTIMATE_LAYOUT)
#: The estimator outputs of recordings made before OPERATING_TIME existed.
LEGACY_ESTIMATOR_TOPICS = ESTIMATOR_TOPICS[:5]
#: The estimator outputs an update cannot be rebuilt without.
REQUIRED_ESTIMATOR_TOPICS = frozenset((FRICTION, FRICTION_COVARIANCE))


def field_index(layout: Layout, topic: str, name: str) -> int:
    """Return which of x, y, z (0, 1, 2) of ``topic`` holds attribute ``name`` of ``layout``.

    Raises KeyError for a topic or attribute the layout does not have.
    """
    for candidate, names in layout:
        if candidate == topic and name in names:
            return names.index(name)
    raise KeyError(f'{topic} holds no {name}')


def stamp_to_ns(stamp: Any) -> int:
    """builtin_interfaces/Time (sec, nanosec) -> integer nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_sec_nanosec(stamp_ns: int) -> tuple[int, int]:
    """Integer nanoseconds -> (sec, nanosec) as in builtin_interfaces/Time."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return sec, nanosec


# --- output records --------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Vector3Out:
    """A geometry_msgs/Vector3Stamped to publish on ``topic``."""

    topic: str
    stamp_ns: int
    x: float
    y: float
    z: float
    frame_id: str = ''


@dataclass(frozen=True)
class DiagnosticsOut:
    """A diagnostic_msgs/DiagnosticArray on /diagnostics."""

    stamp_ns: int
    statuses: tuple[StatusOut, ...]
    topic: str = DIAGNOSTICS


# --- domain records <-> layouts ----------------------------------------------------------------

def _getters(layout: Layout) -> tuple[tuple[str, Callable[[Any], tuple[Any, ...]]], ...]:
    return tuple((topic, operator.attrgetter(*names)) for topic, names in layout)


_ESTIMATE_GETTERS = {False: _getters(ESTIMATE_LAYOUT), True: _getters(estimate_layout(True))}
_HEALTH_GETTERS = _getters(HEALTH_LAYOUT)


def estimate_outputs(estimate: FrictionEstimate, frame_id: str = '',
                     no_load: bool = False) -> list[Vector3Out]:
    """Return the estimator topics of one update, in publishing order.

    :data:`ESTIMATE_LAYOUT`, with ``no_load`` also :data:`NO_LOAD_LAYOUT`.
    """
    stamp = estimate.stamp_ns
    outputs = []
    for topic, get in _ESTIMATE_GETTERS[no_load]:
        x, y, z = get(estimate)
        outputs.append(Vector3Out(topic, stamp, float(x), float(y), float(z), frame_id))
    return outputs


def health_outputs(state: HealthState) -> tuple[Vector3Out, ...]:
    """Return gear_phm/health/rul and gear_phm/health/efficiency of one health state.

    See :data:`HEALTH_LAYOUT`.
    """
    outputs = []
    for topic, get in _HEALTH_GETTERS:
        x, y, z = get(state)
        outputs.append(Vector3Out(topic, state.stamp_ns, float(x), float(y), float(z)))
    return tuple(outputs)


def vector3_columns(records: Sequence[Any], layout: Layout
                    ) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Return the outputs of many records as ``(topic, stamps [ns], N x 3 values)`` columns.

    ``records`` (with ``stamp_ns``) are laid out by ``layout``; the values are those of
    :func:`estimate_outputs` / :func:`health_outputs`, built without a record per message.
    """
    stamps = np.fromiter((r.stamp_ns for r in records), dtype=np.int64, count=len(records))
    row = operator.attrgetter(*(name for _, names in layout for name in names))
    values = np.array([row(r) for r in records], dtype=float).reshape(-1, 3 * len(layout))
    return [(topic, stamps, values[:, 3 * i:3 * i + 3]) for i, (topic, _) in enumerate(layout)]


def vector3_stamped_cdr(output: Vector3Out) -> bytes:
    """Little-endian CDR of a geometry_msgs/Vector3Stamped, packed directly.

    About 50 times faster than the generic serializer; the tests check it is byte-identical.
    """
    sec, nanosec = divmod(int(output.stamp_ns), 1_000_000_000)
    frame, packer = _vector3_packer(output.frame_id)
    return packer(b'\x00\x01\x00\x00', sec, nanosec, len(frame), frame, float(output.x),
                  float(output.y), float(output.z))


def vector3_stamped_columns(buffer: bytes | memoryview, offsets: np.ndarray,
                            lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Decode little-endian CDR geometry_msgs/Vector3Stamped payloads into columns.

    The payloads are ``buffer[offsets[i]:offsets[i] + lengths[i]]``; returns (stamps [ns],
    N x 3 values x, y, z), the inverse of :func:`vector3_stamped_cdr`, by numpy gathers
    (no Python work per message; frame_ids of any length). Payloads too short for their
    frame_id or not little-endian CDR are left out.
    """
    data = np.frombuffer(buffer, dtype=np.uint8)
    offsets = np.asarray(offsets, dtype=np.int64)
    lengths = np.asarray(lengths, dtype=np.int64)
    usable = lengths >= 40                      # header, empty frame_id, padding, 3 doubles
    usable[usable] = data[offsets[usable] + 1] == 1          # CDR_LE encapsulation

    def gather(at: np.ndarray, size: int, dtype: str) -> np.ndarray:
        item = np.dtype(dtype).itemsize
        return data[at[:, None] + np.arange(size)].view(dtype).reshape(at.size, size // item)

    offsets, lengths = offsets[usable], lengths[usable]
    stride = common_stride(data, offsets)
    if stride is not None and (lengths == lengths[0]).all():
        # one size back to back (an MCAP chunk's): strided views, copied out of the chunk
        def view(at: int, dtype: str) -> np.ndarray:
            """Three values of ``dtype`` at byte ``at`` of each payload, (N, 3)."""
            return np.array(np.ndarray((offsets.size, 3), dtype=dtype, buffer=data,
                                       offset=int(offsets[0]) + at,
                                       strides=(stride, np.dtype(dtype).itemsize)))
        sec, nanosec, frame = view(4, '<u4').T
        start = 4 + (12 + int(frame[0]) + 7) // 8 * 8
        if (frame == frame[0]).all() and start + 24 <= int(lengths[0]):
            return (sec.astype(np.int32).astype(np.int64) * 1_000_000_000 + nanosec,
                    view(start, '<f8'))
    sec, nanosec, frame = gather(offsets + 4, 12, '<u4').T
    start = 4 + (12 + frame.astype(np.int64) + 7) // 8 * 8    # x, float64-aligned from byte 4
    fits = start + 24 <= lengths
    values = gather(offsets[fits] + start[fits], 24, '<f8')
    stamps = sec[fits].astype(np.int32).astype(np.int64) * 1_000_000_000 + nanosec[fits]
    return stamps, values


@functools.lru_cache(maxsize=64)
def _vector3_packer(frame_id: str) -> tuple[bytes, Callable[..., bytes]]:
    """(frame_id with its NUL, struct packer) of the Vector3Stamped layout for ``frame_id``."""
    frame = frame_id.encode() + b'\0'
    padding = (-(12 + len(frame))) % 8          # float64 alignment, from the CDR origin
    return frame, struct.Struct(f'<4siII{len(frame)}s{padding}x3d').pack


_ESTIMATE_FIELDS = frozenset(f.name for f in fields(FrictionEstimate))
_COVARIANCE = ('p_uu', 'p_ur', 'p_rr')           # FrictionEstimate.covariance, in its order
_ESTIMATE_INTS = frozenset(f.name for f in fields(FrictionEstimate) if f.type in ('int', int))
#: (topic, required, the FrictionEstimate fields its x, y, z hold; None: derived, not read)
_ESTIMATE_READS = tuple(
    (topic, topic in REQUIRED_ESTIMATOR_TOPICS,
     tuple(name if name in _ESTIMATE_FIELDS or name in _COVARIANCE else None
           for name in names))
    for topic, names in ESTIMATE_LAYOUT)


def estimate_from_vectors(stamp_ns: int, vectors: dict[str, Any]) -> FrictionEstimate:
    """Rebuild an update from its estimator topics (``{topic: object with .x .y .z}``).

    The topics of :data:`REQUIRED_ESTIMATOR_TOPICS` must be there (KeyError otherwise); the
    fields of a missing topic keep the record's defaults: NaN, or zero counts (a missing
    operating time: an older estimator or recording). Non-finite counts read as zero.
    """
    kwargs: dict[str, Any] = {}
    for topic, required, names in _ESTIMATE_READS:
        vector = vectors[topic] if required else vectors.get(topic)
        if vector is None:
            continue
        for name, value in zip(names, (vector.x, vector.y, vector.z)):
            if name is not None:
                value = float(value)
                kwargs[name] = (int(value) if math.isfinite(value) else 0) \
                    if name in _ESTIMATE_INTS else value
    kwargs['covariance'] = tuple(kwargs.pop(name) for name in _COVARIANCE)
    z, z_variance = kwargs.get('measurement', math.nan), kwargs.get('measurement_variance', 0.0)
    if not (math.isfinite(z) and z_variance > 0.0):     # none (NaN), or an older estimator's 0
        kwargs['measurement'] = kwargs['measurement_variance'] = math.nan
    return FrictionEstimate(int(stamp_ns), **kwargs)


def sample_loss_output(stamp_ns: int, samples_missing: int, loss_ratio: float,
                       period_s: float | None, frame_id: str = '') -> Vector3Out:
    """Return the ``gear_phm/sample_loss`` output.

    x = samples missing so far, y = share missing over the last status period, z = expected
    sample period [s] (NaN before it is known).
    """
    return Vector3Out(SAMPLE_LOSS, stamp_ns, float(samples_missing), float(loss_ratio),
                      math.nan if period_s is None else float(period_s), frame_id)


#: KeyValue keys of the diagnostics node's /diagnostics status, in this order (benches rely
#: on them). ``rul_*`` are in elapsed (stamp) time, ``rul_operating_*`` in operating time,
#: ``utilisation`` is their ratio (operating over elapsed time, see
#: :mod:`gear_phm.prognostics.assessor`); ``eta_healthy`` is the healthy eta_D learned at the
#: start and ``eta_warn`` the WARN efficiency in force (``nan`` until learned).
STATUS_KEYS = ('u', 'u_sigma', 'eta_opposing', 'eta_aiding', 'rul_s', 'rul_p5_s', 'rul_p95_s',
               'power_flow', 'samples_used', 'samples_rejected', 'samples_missing',
               'operating_time_s', 'rul_operating_s', 'rul_operating_p5_s',
               'rul_operating_p95_s', 'utilisation', 'eta_healthy', 'eta_warn')


def health_key_values(state: HealthState) -> tuple[tuple[str, str], ...]:
    """Return KeyValue pairs with exactly :data:`STATUS_KEYS` (decimal strings, ``inf``)."""
    values = (state.u, state.u_sigma, state.eta_opposing, state.eta_aiding, state.rul.median,
              state.rul.p5, state.rul.p95, state.power_flow, state.samples_used,
              state.samples_rejected, state.samples_missing, state.operating_time,
              state.rul_operating.median, state.rul_operating.p5, state.rul_operating.p95,
              state.utilisation, state.eta_healthy, state.eta_warn)
    return tuple(zip(STATUS_KEYS, format_values(values)))


def health_status(state: HealthState, transmission_name: str, hardware_id: str) -> StatusOut:
    """Return the diagnostics node's DiagnosticStatus ``gear_phm: <transmission_name>``."""
    return StatusOut(state.level, f'gear_phm: {transmission_name}', state.message,
                     hardware_id, health_key_values(state))
