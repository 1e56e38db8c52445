"""Shared rclpy helpers: QoS, parameter declaration, /diagnostics, main()."""
from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
import faulthandler
import math
import signal
import sys
import threading
from typing import Any, TypeVar

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from gear_phm.errors import GearPhmError
from gear_phm.interfaces import DiagnosticsOut, ns_to_sec_nanosec, Vector3Out
from gear_phm.parameters import ParamSpec
from gear_phm.status import format_value, StatusOut

NodeT = TypeVar('NodeT', bound=Node)


def sensor_qos(depth: int = 100) -> QoSProfile:
    """qos_profile_sensor_data (best effort, volatile, keep last) with a deeper queue.

    The stock depth of 5 loses samples whenever the executor is busy for more than 5 sample
    periods (measured: 1.3-2.8 % lost by a bare subscriber at 1 kHz on 2 cores; 0 with 100).
    """
    return QoSProfile(depth=depth, reliability=qos_profile_sensor_data.reliability,
                      durability=qos_profile_sensor_data.durability,
                      history=qos_profile_sensor_data.history)


#: Sensor inputs: the policies of qos_profile_sensor_data, depth 100.
SENSOR_QOS = sensor_qos()
#: Outputs: reliable, keep last 10.
OUTPUT_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


class ConfigError(GearPhmError):
    """Invalid start-up configuration: printed on one line by :func:`run_node`, exit 2."""


def declare(node: Node, name: str, default: Any, description: str, *,
            low: float | int | None = None, high: float | int | None = None,
            constraints: str = '', read_only: bool = False, required: bool = False) -> Any:
    """Declare a parameter with a ParameterDescriptor (description, range) and return its value.

    ``low``/``high`` set a FloatingPointRange for floats or an IntegerRange for ints (step 0).
    A value outside the range is refused by rclpy with its own reason. ``required``: declared
    with the type of ``default`` and no value (None unless set by the user).
    """
    descriptor = ParameterDescriptor(description=description, read_only=read_only,
                                     additional_constraints=constraints)
    if low is not None or high is not None:
        if isinstance(default, bool) or not isinstance(default, (int, float)):
            raise TypeError(f'range given for non-numeric parameter {name}')
        if isinstance(default, float):
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(-sys.float_info.max if low is None else low),
                to_value=float(sys.float_info.max if high is None else high), step=0.0)]
        else:
            descriptor.integer_range = [IntegerRange(
                from_value=int(-2**62 if low is None else low),
                to_value=int(2**62 if high is None else high), step=0)]
    if required:
        return node.declare_parameter(name, _TYPES[type(default)], descriptor).value
    return node.declare_parameter(name, default, descriptor).value


def declare_parameters(node: Node, specs: Iterable[ParamSpec]) -> dict[str, Any]:
    """Declare each spec as a ROS parameter with its descriptor; return ``{name: value}``.

    The descriptor holds the description with unit, range, choices and read-only. A value
    rclpy refuses, or one outside the spec's choices, raises :class:`ConfigError` naming the
    parameter.
    """
    return {spec.name: _declare_spec(node, spec, required=False) for spec in specs}


def declare_required(node: Node, specs: Iterable[ParamSpec]) -> dict[str, Any]:
    """Declare specs that have no default (``spec.default`` gives the type only).

    Return ``{name: value}`` of those set (by a parameters file or ``-p``); one left unset is
    absent. Raises :class:`ConfigError` as :func:`declare_parameters`.
    """
    values = {spec.name: _declare_spec(node, spec, required=True) for spec in specs}
    return {name: value for name, value in values.items() if value is not None}


#: Parameters that were renamed: the old name, and what to set instead.
RENAMED = {'self_locking_eol': 'must_back_drive (true: a drive worn into self-locking is at '
                               'end of life; the old default true is must_back_drive true)'}


def check_overrides(node: Node) -> None:
    """Refuse a renamed parameter and warn of any other override this node did not declare.

    rclpy drops the value of a parameter that a parameters file or ``-p`` sets but the node
    does not declare; a misspelt or renamed name would then be lost without a word. Raises
    :class:`ConfigError` naming a renamed parameter and its replacement; logs one warning line
    naming the others (``qos_overrides.*`` are rclpy's own).
    """
    overrides = getattr(node, '_parameter_overrides', {})
    unknown = sorted(name for name in overrides
                     if not node.has_parameter(name) and not name.startswith('qos_overrides.'))
    renamed = [name for name in unknown if name.split('.')[-1] in RENAMED]
    if renamed:
        name = renamed[0]
        msg = f'parameter {name} was replaced by {RENAMED[name.split(".")[-1]]}'
        raise ConfigError(msg)
    if unknown:
        node.get_logger().warning(f'ignored parameters (not parameters of {node.get_name()}): '
                                  f'{", ".join(unknown)}')


_TYPES = {bool: Parameter.Type.BOOL, int: Parameter.Type.INTEGER,
          float: Parameter.Type.DOUBLE, str: Parameter.Type.STRING}


def _declare_spec(node: Node, spec: ParamSpec, required: bool) -> Any:
    """Declare one spec (its default, or its type only if ``required``); its checked value."""
    low, high = spec.low, spec.high
    if spec.kind is float and high is not None:
        high = min(high, 1e300)              # a FloatingPointRange holds no inf
    constraints = f'one of {", ".join(map(repr, spec.choices))}' if spec.choices else ''
    if spec.nan_means:                    # a FloatingPointRange would refuse the NaN
        span = (-math.inf if low is None else low, math.inf if high is None else high)
        constraints = f'nan ({spec.nan_means}) or in [{span[0]:g}, {span[1]:g}]'
        low = high = None
    try:
        value = declare(node, spec.name, spec.default, spec.text, low=low, high=high,
                        constraints=constraints, read_only=spec.read_only,
                        required=required)
        return None if value is None else spec.check(value)
    except (ParameterException, ValueError) as exc:
        raise ConfigError(f'parameter {spec.name}: {" ".join(str(exc).split())}') \
            from None


def stamp(stamp_ns: int) -> Time:
    """builtin_interfaces/Time from integer nanoseconds."""
    sec, nanosec = ns_to_sec_nanosec(stamp_ns)
    return Time(sec=sec, nanosec=nanosec)


def to_rclpy(output: Vector3Out | DiagnosticsOut) -> Vector3Stamped | DiagnosticArray:
    """Return the rclpy message of an output record.

    The offline twin is gear_phm.bagio.to_rosbags.
    """
    if isinstance(output, Vector3Out):
        msg = Vector3Stamped()
        msg.header.stamp = stamp(output.stamp_ns)
        msg.header.frame_id = output.frame_id
        msg.vector.x, msg.vector.y, msg.vector.z = (float(output.x), float(output.y),
                                                    float(output.z))
        return msg
    msg = DiagnosticArray()
    msg.header.stamp = stamp(output.stamp_ns)
    msg.status = [status_msg(s) for s in output.statuses]
    return msg


def status_msg(status: StatusOut) -> DiagnosticStatus:
    """diagnostic_msgs/DiagnosticStatus; the level goes in as a byte, as diagnostic_updater."""
    return DiagnosticStatus(level=bytes([int(status.level)]), name=status.name,
                            message=status.message, hardware_id=status.hardware_id,
                            values=[KeyValue(key=k, value=v) for k, v in status.values])


def qualified(node: Node, name: str) -> str:
    """Return ``name`` under ``node``'s namespace (``r1/gearbox``; the root's: ``name`` itself).

    The default status names are thus unique among nodes of one name in other namespaces.
    """
    namespace = node.get_namespace().strip('/')
    return f'{namespace}/{name}' if namespace else name


#: The /diagnostics key that counts the resets by ``~/reset`` since the node started.
RESETS = 'resets'


def reset_service(node: Node, name: str, reset: Callable[[], str]) -> Any:
    """Serve ``std_srvs/srv/Trigger`` ``name`` (e.g. ``~/reset``): learning reset on purpose.

    ``reset()`` forgets what was learned and returns what it did (the response's message and
    one log line). Returns the service.
    """
    from std_srvs.srv import Trigger

    def serve(_request: Any, response: Any) -> Any:
        what = reset()
        node.get_logger().info(f'{node.resolve_service_name(name)}: {what}')
        response.success, response.message = True, what
        return response
    return node.create_service(Trigger, name, serve)


class DropCounter:
    """Counts used and dropped messages by reason, for a node's own /diagnostics status."""

    def __init__(self) -> None:
        self.received = 0
        self.dropped: Counter[str] = Counter()

    def drop(self, reason: str) -> None:
        self.dropped[reason] += 1

    @property
    def dropped_total(self) -> int:
        return sum(self.dropped.values())

    def status(self, name: str, hardware_id: str, level: int, message: str,
               extra: Sequence[tuple[str, Any]] = ()) -> StatusOut:
        """Return a StatusOut with received/dropped counts, one ``dropped_<reason>`` per reason."""
        values = [('messages_received', format_value(self.received)),
                  ('messages_dropped', format_value(self.dropped_total))]
        values += [(f'dropped_{reason}', format_value(count))
                   for reason, count in sorted(self.dropped.items())]
        values += [(key, format_value(value)) for key, value in extra]
        return StatusOut(level=level, name=name, message=message, hardware_id=hardware_id,
                         values=tuple(values))


#: The longest a node process's spin loop waits before it sees a SIGINT or SIGTERM, s.
SPIN_TIMEOUT_S = 0.1

_STOP = threading.Event()


def _request_stop(signum: int, _frame: object) -> None:
    if _STOP.is_set():                  # a second signal while stopping: stop now
        raise KeyboardInterrupt
    _STOP.set()


@contextmanager
def stop_signals() -> Iterator[None]:
    """Turn SIGINT and SIGTERM into a stop request that the main thread's loop polls.

    Use with ``rclpy.init(signal_handler_options=SignalHandlerOptions.NO)``
    (:func:`init_node_process`). rclpy's own handlers shut the context down from their own
    thread while the main thread may be in a callback or already destroying the node: in CI
    the diagnostics node once exited on SIGSEGV (-11) at SIGINT, after closing its recording.
    Here the handler only sets a flag; the loop (:func:`keep_spinning`) sees it within
    :data:`SPIN_TIMEOUT_S`, and the main thread stops in order: leave the loop, destroy the
    node (state file, recording), shut the context down. A second signal while stopping
    raises KeyboardInterrupt (stop now, as a second Ctrl-C does elsewhere).
    """
    _STOP.clear()
    previous = {sig: signal.signal(sig, _request_stop) for sig in (signal.SIGINT,
                                                                   signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def init_node_process(args: Sequence[str] | None) -> None:
    """``rclpy.init`` for a process that stops through :func:`stop_signals`.

    Raises :class:`ConfigError` if rclpy refuses the arguments (a params file that does not
    parse, a bad ``--ros-args`` rule). Also turns on :mod:`faulthandler`: a crash in native
    code (rmw, DDS) prints every thread's Python stack to stderr, for the bug report.
    """
    faulthandler.enable()
    try:
        rclpy.init(args=None if args is None else list(args),
                   signal_handler_options=SignalHandlerOptions.NO)
    except RuntimeError as exc:     # rclpy's RCLError: e.g. a params file that does not parse
        msg = f'cannot start ROS: {" ".join(str(exc).split())}'
        raise ConfigError(msg) from None


def keep_spinning(context: Any = None) -> bool:
    """Return False once a stop was requested (:func:`stop_signals`) or the context is down."""
    return not _STOP.is_set() and rclpy.ok(context=context)


def stopped_by_signal(exc: BaseException) -> bool:
    """Tell whether an error is a clean stop.

    A clean stop is KeyboardInterrupt (a second SIGINT/SIGTERM while stopping, see
    :func:`stop_signals`), ExternalShutdownException, or a RuntimeError (rclpy's RCLError, or
    pybind11's "Unable to convert call argument" in a take) raised because the context was
    shut down under a callback (rclpy's own signal handlers do that where they are installed).
    Any other error is real.
    """
    if isinstance(exc, (KeyboardInterrupt, ExternalShutdownException)):
        return True
    return isinstance(exc, RuntimeError) and not rclpy.ok()


def run_node(factory: Callable[[], NodeT], args: Sequence[str] | None = None,
             spin: Callable[[NodeT], None] | None = None) -> int:
    """Jazzy main(): init, build, spin, ordered shutdown. ConfigError at start -> one line, exit 2.

    ``spin`` replaces the default loop (``spin_once`` while :func:`keep_spinning`), e.g. for a
    node that finishes by itself; it must poll :func:`keep_spinning`. SIGINT and SIGTERM stop
    the loop (:func:`stop_signals`); the node is then destroyed and the context shut down, in
    this thread.
    """
    try:
        init_node_process(args)
    except ConfigError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    node = None
    with stop_signals():
        try:
            node = factory()
            if spin is None:
                while keep_spinning(node.context):
                    rclpy.spin_once(node, timeout_sec=SPIN_TIMEOUT_S)
            else:
                spin(node)
            return 0
        except ConfigError as exc:
            print(f'error: {exc}', file=sys.stderr)
            return 2
        except BaseException as exc:
            if stopped_by_signal(exc):
                return 0
            raise
        finally:
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
