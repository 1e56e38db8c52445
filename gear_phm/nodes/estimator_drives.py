"""The estimator node serving many drives (``transmissions`` non-empty).

One JointState stream carries every drive's joints. Each serialized message is buffered as it
arrives (its stamp read with one ``struct`` call); a buffer is decoded once for all drives by
:func:`gear_phm.codec.decode_joint_state_pairs` (each layout parsed once) and each drive's
columns go to its own :class:`~gear_phm.estimation.EstimatorPipeline`. The buffer is
processed when a sample crosses the earliest drive's publish_rate grid, ``batch_period``
after its first sample, or at 200 samples (so a drive's outputs leave at most about
``batch_period`` after the sample that closed a window). Outputs are each drive's, on
``gear_phm/<drive>/...`` with the single transmission's layouts; the /diagnostics array holds
one status per drive, ``gear_phm estimator: <drive>`` (``hardware_id`` the drive; as
``gear-phm analyze --transmissions``),
whose counters are that drive's alone (a missing, short or NaN joint of one drive counts
against it only). A drive with no sample for its ``sensor_timeout`` is flagged on its own.
The per-drive parameters are read-only (restart the node to change them); ``frame_id`` and
``use_sim_time`` apply at run time. ``~/<drive>/reset``
resets one drive's learning, ``~/reset`` every drive's (``std_srvs/srv/Trigger``); each
drive's status counts its resets (``resets``).
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import replace
from functools import partial
import struct
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node

from gear_phm import interfaces
from gear_phm.codec import decode_joint_state_pairs, packed
from gear_phm.interfaces import DiagnosticsOut
from gear_phm.nodes.common import (ConfigError, OUTPUT_QOS, qualified, reset_service, RESETS,
                                   to_rclpy)
from gear_phm.nodes.state import (DRIVES_IDENTITY, drives_restorer, drives_state,
                                  estimator_identity, StateKeeper)
from gear_phm.nodes.transport import (EstimatePublisher, JointNames, OUTPUTS_MATCHED,
                                      SampleLossPublisher, subscribe_joint_states_raw)
from gear_phm.run import DriveEstimator, DriveNames
from gear_phm.transmissions import Transmission

#: A buffer this long is processed at once.
MAX_BUFFER = 200
_STAMP = struct.Struct('<iI').unpack_from


class _Drive:
    """One drive's run (:class:`~gear_phm.run.DriveEstimator`) and its publishers."""

    def __init__(self, node: Node, drive: Transmission, frame_id: str) -> None:
        self.drive = drive
        try:
            names = DriveNames.of(drive.name)
            self.run = DriveEstimator(drive.estimator_config(), replace(
                names, estimator_status=f'gear_phm estimator: {qualified(node, drive.name)}'))
        except ValueError as exc:
            raise ConfigError(f'drive {drive.name}: {exc}') from None
        self.pipeline = self.run.pipeline
        topics = self.run.names.topic
        self.outputs = EstimatePublisher(node, frame_id, topics,
                                         no_load=self.pipeline.config.no_load_model)
        self.loss_outputs = SampleLossPublisher(node, frame_id, topics)

    @property
    def identity(self) -> dict[str, Any]:
        """Return what the state file must match for this drive."""
        drive = self.drive
        return estimator_identity(drive.ratio, drive.motor_joint, drive.load_joint)


class DrivesEstimator:
    """The estimator of many drives inside ``node`` (module docstring)."""

    def __init__(self, node: Node, drives: tuple[Transmission, ...],
                 values: dict[str, Any]) -> None:
        self.node = node
        self.drives = [_Drive(node, drive, values['frame_id']) for drive in drives]
        self.pairs = [(d.motor_joint, d.load_joint) for d in drives]
        self.state = StateKeeper(node, values, 'estimator', DRIVES_IDENTITY,
                                 self._current_state)
        self.state.load(drives_restorer(self.state, {d.drive.name: d.identity
                                                     for d in self.drives},
                                        {d.drive.name: d.pipeline.from_state
                                         for d in self.drives}))
        self.diag_pub = node.create_publisher(DiagnosticArray, interfaces.DIAGNOSTICS,
                                              OUTPUT_QOS)
        self.messages_received = 0
        self.joint_names = JointNames()         # of messages without a drive's joints
        self.raws: list[bytes] = []
        self._due: int | None = None
        self.batch_timer = node.create_timer(values['batch_period'], self.flush)
        self.batch_timer.cancel()
        node.create_timer(values['diagnostics_period'], self._on_diagnostics_timer)
        self.subscription = subscribe_joint_states_raw(node, self._on_message)
        for d in self.drives:
            reset_service(node, f'~/{d.drive.name}/reset', partial(self._reset, [d]))
        reset_service(node, '~/reset', lambda: self._reset(self.drives))
        node.add_post_set_parameters_callback(self._apply_parameters)
        self.state.start_timer(self._save_state)

    def _apply_parameters(self, params: Sequence[Any]) -> None:
        """Post-set: a new frame_id labels the outputs from now on (the others are refused)."""
        for param in params:
            if param.name == 'frame_id':
                for d in self.drives:
                    d.outputs.frame_id = d.loss_outputs.frame_id = param.value

    def _reset(self, drives: list[_Drive]) -> str:
        """Forget what ``drives`` learned (a reset service); save the state file at once."""
        self.flush()
        for d in drives:
            d.run.reset()
        self._due = None
        self.state.save()
        names = ', '.join(d.drive.name for d in drives)
        return f'learning reset of {names}: u back to the prior'

    def _current_state(self) -> tuple[dict[str, Any], int | None]:
        parts = {}
        for d in self.drives:
            state = d.pipeline.to_state()
            parts[d.drive.name] = (d.identity, state, state['last_stamp'])
        return drives_state(parts)

    def _save_state(self) -> None:
        self.flush()
        self.state.save()

    def close(self) -> None:
        """Process the buffer without publishing and save the state (before destroy_node)."""
        if self.state.enabled:
            self._process(publish=False)
        self.state.save()

    def _on_message(self, raw: bytes) -> None:
        """One serialized JointState: buffer it; process the buffer when an output is due."""
        self.messages_received += 1         # counted on arrival (a buffer waits up to
        self.raws.append(raw)               # batch_period)
        due = self._due
        if due is not None and len(raw) >= 12:
            sec, nanosec = _STAMP(raw, 4)
            if sec * 1_000_000_000 + nanosec >= due:
                self.flush()
                return
        if len(self.raws) >= MAX_BUFFER:
            self.flush()
        elif len(self.raws) == 1:
            self.batch_timer.reset()

    def flush(self) -> None:
        """Process the buffer and publish what is due.

        The next flush is due at the earliest drive's next output, among the outputs still
        ahead of the newest stamp buffered: a drive whose samples stopped (its joints cut)
        keeps an output due in the past, and made every later message a flush of its own for
        every drive (8 drives, one cut: ~2 messages a flush instead of ~100, 5x the CPU).
        """
        self.batch_timer.cancel()
        newest = max((_STAMP(raw, 4) for raw in self.raws if len(raw) >= 12), default=None)
        self._process(publish=True)
        after = -1 if newest is None else newest[0] * 1_000_000_000 + newest[1]
        dues = [due for d in self.drives
                if (due := d.pipeline.next_output_stamp()) is not None and due > after]
        self._due = min(dues) if dues else None

    def _process(self, publish: bool) -> None:
        raws = self.raws
        if not raws:
            return
        self.raws = []
        now = self.node.get_clock().now().nanoseconds
        buffer = packed(raws)
        batches = decode_joint_state_pairs(*buffer, self.pairs)
        for d, batch in zip(self.drives, batches):
            pipeline = d.pipeline
            for reason, count in Counter(reason for _, reason in batch.rejected_at).items():
                pipeline.reject_message(reason, count)
            if batch.rejected_at and not pipeline.samples_seen:
                self.joint_names.note(*buffer)
            if not len(batch):
                d.run.watch(now)
                continue
            d.run.last_sample_ns = now
            try:
                outputs = pipeline.on_batch(batch.stamp_ns, batch.motor_velocity,
                                            batch.motor_effort, batch.load_velocity,
                                            batch.load_effort)
            except Exception as exc:  # never die on data; count it
                pipeline.reject_message('bad_message', len(batch))
                self.node.get_logger().warn(
                    f'{d.drive.name}: dropped {len(batch)} joint_states sample(s): {exc}',
                    throttle_duration_sec=5.0)
                continue
            if publish:
                d.outputs.publish(outputs)

    def _on_diagnostics_timer(self) -> None:
        now = self.node.get_clock().now().nanoseconds
        self.flush()
        statuses = []
        for d in self.drives:
            d.run.watch(now)
            status = self.joint_names.status(
                d.run.status(self.messages_received),
                d.pipeline.samples_seen, d.drive.motor_joint, d.drive.load_joint)
            statuses.append(self.state.flagged(replace(
                status, hardware_id=d.drive.name,
                values=status.values + ((OUTPUTS_MATCHED, str(d.outputs.matched())),
                                        (RESETS, str(d.run.resets))))))
        self.diag_pub.publish(to_rclpy(DiagnosticsOut(now, tuple(statuses))))
        for d in self.drives:
            d.loss_outputs.publish(d.pipeline)
