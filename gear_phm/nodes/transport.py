"""The live transport: domain records <-> rclpy messages on the nodes' topics.

With :mod:`gear_phm.interfaces` (topic names and field layouts, shared with the bag side) this
is the only place that knows which topic carries what. The estimator node takes JointState
serialized (:func:`subscribe_joint_states_raw`; decoded by :class:`gear_phm.codec.
JointStateDecoder`, the codec the bag side uses too), publishes each
:class:`~gear_phm.estimation.FrictionEstimate` as seven Vector3Stamped topics with one stamp
(:class:`EstimatePublisher`) and its loss count (:class:`SampleLossPublisher`); the
diagnostics node puts the seven back together into the same record
(:class:`EstimateAssembler`, an exact-time synchronizer as in message_filters) and hands
whole updates to its :class:`~gear_phm.prognostics.HealthAssessor`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState, Temperature

from gear_phm import codec, interfaces
from gear_phm.estimation.records import FrictionEstimate
from gear_phm.nodes.common import OUTPUT_QOS, SENSOR_QOS, stamp, to_rclpy
from gear_phm.prognostics.assessor import HealthState
from gear_phm.run.names import same_topic
from gear_phm.status import StatusOut

#: A drive's topic of each topic (:attr:`gear_phm.run.DriveNames.topic`).
Topics = Callable[[str], str]

#: Pending stamps kept while waiting for the rest of an update; older ones are processed.
MAX_PENDING_STAMPS = 64
#: Later updates with the five legacy topics after which an update without operating time is
#: taken as an older estimator's (EstimateAssembler).
LEGACY_LAG = 3
#: Later complete updates after which an update still missing a topic is processed without
#: it (EstimateAssembler). Within the outputs' depth 10: a topic that lags by more loses
#: messages in its queue anyway.
STRAGGLER_LAG = 8
#: Stamps further back than this are a new run (replay restarted), not stragglers [ns].
RESTART_JUMP_NS = 10 * 10**9


def subscribe_joint_states_raw(node: Node, on_message: Callable[[bytes], None]) -> Any:
    """Subscribe ``joint_states`` (sensor QoS) serialized.

    ``on_message`` gets the CDR bytes of each message, with no Python message object built
    (decode them with :class:`gear_phm.codec.JointStateDecoder`).
    """
    return node.create_subscription(JointState, interfaces.JOINT_STATES, on_message,
                                    SENSOR_QOS, raw=True)


class JointNames:
    """The joint-name lists of the first rejected JointState messages, for the status.

    While no message has had the drive's joints, the estimator's status says which joints the
    messages do name (:func:`gear_phm.codec.joints_hint`): a wrong ``motor_joint`` is then
    plain on /diagnostics. At most :attr:`KEEP` distinct lists are kept.
    """

    KEEP = 4

    def __init__(self) -> None:
        self.names: list[tuple[str, ...]] = []
        self._looks = 0

    def note(self, buffer: bytes, offsets: Any, lengths: Any) -> None:
        """Keep the names of payloads whose joints were not found (the first KEEP calls)."""
        if self._looks < self.KEEP:
            self._looks += 1
            for names in codec.joint_names(buffer, offsets, lengths, self.KEEP):
                if names not in self.names and len(self.names) < self.KEEP:
                    self.names.append(names)

    def status(self, status: StatusOut, samples_seen: int, motor_joint: str,
               load_joint: str) -> StatusOut:
        """``status`` with the hint appended while no sample was seen."""
        hint = codec.joints_hint(self.names, motor_joint, load_joint) if not samples_seen \
            else ''
        return replace(status, message=f'{status.message}; {hint}') if hint else status


#: The estimator status's key: the fewest subscriptions matched by its seven output topics'
#: publishers (:meth:`EstimatePublisher.matched`); 0 while no diagnostics node listens.
OUTPUTS_MATCHED = 'outputs_matched'


class EstimatePublisher:
    """Publishes estimates on the seven estimator topics (reliable, depth 10).

    ``topics``: the drive's topic of each topic (:attr:`gear_phm.run.DriveNames.topic`; a
    drive of ``transmissions`` publishes ``gear_phm/<drive>/...``).
    """

    def __init__(self, node: Node, frame_id: str = '', topics: Topics = same_topic,
                 no_load: bool = False) -> None:
        self.frame_id = frame_id
        self.no_load = no_load          # also gear_phm/no_load (the no-load model's outputs)
        self._publishers = {topic: node.create_publisher(Vector3Stamped,
                                                         topics(topic), OUTPUT_QOS)
                            for topic, _ in interfaces.estimate_layout(no_load)}

    def matched(self) -> int:
        """Return the subscriptions matched by every one of the seven topics' publishers.

        The fewest of the seven: a diagnostics node assembles an update from all of them,
        and an estimate published before its reader matched is lost to it.
        """
        return min(publisher.get_subscription_count()
                   for publisher in self._publishers.values())

    def publish(self, estimates: list[FrictionEstimate]) -> None:
        """Publish each estimate on the seven topics, serialized by the package's packer.

        rclpy's ``publish`` takes CDR bytes: no Python message object per output.
        """
        for estimate in estimates:
            for output in interfaces.estimate_outputs(estimate, self.frame_id, self.no_load):
                self._publishers[output.topic].publish(interfaces.vector3_stamped_cdr(output))


class ExtendedTruthPublisher:
    """The simulator's no-load and oil truth and the oil temperature of one drive.

    geometry_msgs/Vector3Stamped on ``gear_phm/truth/no_load`` and ``gear_phm/truth/oil``
    (``extended``; layouts :data:`gear_phm.interfaces.TRUTH_LAYOUT`), sensor_msgs/Temperature
    on ``oil_temperature`` (``temperature``; variance 0). ``topics``: as
    :class:`EstimatePublisher`.
    """

    def __init__(self, node: Node, extended: bool, temperature: bool,
                 topics: Topics = same_topic) -> None:
        self._vectors = [node.create_publisher(Vector3Stamped, topics(topic),
                                               OUTPUT_QOS)
                         for topic in (interfaces.TRUTH_NO_LOAD, interfaces.TRUTH_OIL)
                         ] if extended else []
        self._temperature = node.create_publisher(
            Temperature, topics(interfaces.OIL_TEMPERATURE), OUTPUT_QOS) \
            if temperature else None

    @property
    def publishers(self) -> list[Any]:
        """Every publisher of this drive's topics."""
        return [*self._vectors, *([self._temperature] if self._temperature else [])]

    def publish(self, stamp_ns: int, no_load: tuple[float, ...], oil: tuple[float, ...],
                temperature: float | None) -> None:
        """Publish one instant: no-load (x, y, z), oil (x, y, z), the oil temperature [degC]."""
        for publisher, values in zip(self._vectors, (no_load, oil)):
            msg = Vector3Stamped()
            msg.header.stamp = stamp(stamp_ns)
            msg.vector.x, msg.vector.y, msg.vector.z = (float(v) for v in values)
            publisher.publish(msg)
        if self._temperature is not None and temperature is not None:
            message = Temperature()
            message.header.stamp = stamp(stamp_ns)
            message.temperature = float(temperature)
            message.variance = 0.0
            self._temperature.publish(message)


class SampleLossPublisher:
    """Publishes the estimator's loss count on ``gear_phm/sample_loss`` once per status period.

    Stamped with the newest accepted sample (nothing when no new sample came). ``topics``: as
    :class:`EstimatePublisher`.
    """

    def __init__(self, node: Node, frame_id: str = '', topics: Topics = same_topic) -> None:
        self.frame_id = frame_id
        self._publisher = node.create_publisher(
            Vector3Stamped, topics(interfaces.SAMPLE_LOSS), OUTPUT_QOS)
        self._last_stamp: int | None = None

    def publish(self, pipeline: Any) -> None:
        """``pipeline``: an :class:`~gear_phm.estimation.EstimatorPipeline`."""
        stamp_ns = pipeline.screen.last
        if stamp_ns is None or stamp_ns == self._last_stamp:
            return
        self._last_stamp = stamp_ns
        period = pipeline.screen.period_ns
        output = interfaces.sample_loss_output(stamp_ns, pipeline.samples_missing,
                                               pipeline.loss_ratio,
                                               None if period is None else period * 1e-9,
                                               self.frame_id)
        self._publisher.publish(to_rclpy(output))


class HealthPublisher:
    """Publishes health states on ``gear_phm/health/rul`` and ``gear_phm/health/efficiency``.

    ``record`` (optional) also gets each message with its topic; ``topics``: as
    :class:`EstimatePublisher` (``record`` gets the drive's topic).
    """

    def __init__(self, node: Node, record: Callable[[str, Any], None] | None = None,
                 topics: Topics = same_topic) -> None:
        self._publishers = {topics(topic): node.create_publisher(
            Vector3Stamped, topics(topic), OUTPUT_QOS)
            for topic in (interfaces.HEALTH_RUL, interfaces.HEALTH_EFFICIENCY)}
        self._topics = topics
        self._record = record

    def topic_names(self) -> dict[str, str]:
        """{topic: resolved name}."""
        return {topic: publisher.topic_name for topic, publisher in self._publishers.items()}

    def publish(self, state: HealthState, efficiency_only: bool = False) -> None:
        rul, efficiency = interfaces.health_outputs(state)
        for output in (efficiency,) if efficiency_only else (rul, efficiency):
            msg = to_rclpy(output)
            topic = self._topics(output.topic)
            self._publishers[topic].publish(msg)
            if self._record is not None:
                self._record(topic, msg)


class EstimateAssembler:
    """The estimator's topics in, whole :class:`FrictionEstimate` records out.

    Messages are grouped by stamp; a group is complete with all seven estimator topics, and
    groups are processed in stamp order: one that misses a topic holds the later ones back
    until it is complete or :data:`STRAGGLER_LAG` later groups are (then it goes without the
    topic, counted as ``partial_update``). The seven subscriptions are taken in turn, and
    under load one topic's message can come after the next update's others; an update
    processed then without its window measurement (``gear_phm/operating_time`` y, z) is
    missing from the RUL's history. Until ``gear_phm/operating_time`` has been seen (an older
    estimator or bag does not publish it), a group with the five of
    :data:`~gear_phm.interfaces.LEGACY_ESTIMATOR_TOPICS` is complete
    once :data:`LEGACY_LAG` later groups have those five too: that many updates late, and its
    estimate carries no operating time (the assessor then uses the stamps). Stragglers of an
    update already processed are dropped (``late_stamp``); when more than
    :data:`MAX_PENDING_STAMPS` stamps wait, the oldest are processed if they hold at least
    friction and covariance, else dropped (``incomplete_update``). A jump back by more than
    :data:`RESTART_JUMP_NS` is a replay that restarted, not a straggler. ``dropped`` counts
    by reason.
    """

    def __init__(self) -> None:
        self.pending: dict[int, dict[str, Any]] = {}
        self.dropped: dict[str, int] = {}
        self.last_stamp: int | None = None
        #: Topics a group needs to be complete (grows to all estimator topics once seen).
        self.expected = set(interfaces.LEGACY_ESTIMATOR_TOPICS)

    def _drop(self, reason: str) -> None:
        self.dropped[reason] = self.dropped.get(reason, 0) + 1

    def subscribe(self, node: Node, qos: QoSProfile,
                  on_estimates: Callable[[list[FrictionEstimate]], None],
                  on_message: Callable[[str, Vector3Stamped], None] | None = None,
                  topics: Topics = same_topic) -> None:
        """Subscribe the seven topics (the drive's ``topics``: as :class:`EstimatePublisher`).

        ``on_estimates`` gets each completed update, ``on_message`` (optional) every raw message
        first with its topic (the drive's), e.g. to record it.
        """
        for topic in interfaces.ESTIMATOR_TOPICS:
            def callback(msg: Vector3Stamped, topic: str = topic) -> None:
                if on_message is not None:
                    on_message(topics(topic), msg)
                estimates = self.add(topic, interfaces.stamp_to_ns(msg.header.stamp),
                                     msg.vector)
                if estimates:
                    on_estimates(estimates)
            node.create_subscription(Vector3Stamped, topics(topic), callback, qos)

    def add(self, topic: str, stamp_ns: int, vector: Any) -> list[FrictionEstimate]:
        """One estimator message (``vector`` has .x .y .z); the updates it completes."""
        last = self.last_stamp
        self.expected.add(topic)
        if last is not None and stamp_ns <= last and stamp_ns not in self.pending \
                and last - stamp_ns < RESTART_JUMP_NS:
            self._drop('late_stamp')       # a straggler of an update already processed
            return []
        group = self.pending.setdefault(stamp_ns, {})
        group[topic] = vector
        if interfaces.OPERATING_TIME in self.expected and self.expected.issubset(group):
            return self._ready()
        if interfaces.OPERATING_TIME not in self.expected and self.expected.issubset(group):
            # an older estimator: an update is complete once LEGACY_LAG later ones are. A
            # current one sends the operating time of an update before the next update, but
            # a node that takes its subscriptions in turn (rclpy's SingleThreadedExecutor) may
            # take it after the next update's topics: with a lag of 1, the first update then
            # went without operating time, and the diagnostics test's healthy start read
            # "RUL 510 s < 600 s" (WARN at 80 s, OK again at 850 s) under the suite's load
            complete = sorted(s for s, held in self.pending.items()
                              if self.expected.issubset(held))
            if len(complete) > LEGACY_LAG:
                return self.flush(up_to=complete[-LEGACY_LAG - 1])
        if len(self.pending) > MAX_PENDING_STAMPS:
            return self.flush(up_to=min(self.pending))
        return []

    def _ready(self) -> list[FrictionEstimate]:
        """Return the complete groups from the oldest on, up to the first that still waits.

        A group missing a topic waits until STRAGGLER_LAG later groups are complete.
        """
        estimates: list[FrictionEstimate] = []
        while self.pending:
            stamps = sorted(self.pending)
            complete = [self.expected.issubset(self.pending[s]) for s in stamps]
            if all(complete):
                return estimates + self.flush()
            waiting = complete.index(False)
            if sum(complete[waiting + 1:]) <= STRAGGLER_LAG:
                if waiting:
                    estimates += self.flush(up_to=stamps[waiting - 1])
                return estimates
            self._drop('partial_update')      # given up on its missing topic: counted
            estimates += self.flush(up_to=stamps[waiting])
        return estimates

    def flush(self, up_to: int | None = None) -> list[FrictionEstimate]:
        """Pending groups with stamps <= ``up_to`` (all if None), in stamp order."""
        estimates: list[FrictionEstimate] = []
        for stamp_ns in sorted(s for s in self.pending if up_to is None or s <= up_to):
            group = self.pending.pop(stamp_ns)
            if not interfaces.REQUIRED_ESTIMATOR_TOPICS.issubset(group):
                self._drop('incomplete_update')
                continue
            estimates.append(interfaces.estimate_from_vectors(stamp_ns, group))
            self.last_stamp = stamp_ns
        return estimates
