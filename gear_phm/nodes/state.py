"""``state_file`` of the live nodes: load at start, save periodically and at shutdown.

The document and its atomic write are :mod:`gear_phm.persistence`. Outcomes at start:

- ``state_file`` empty: no persistence.
- missing file: start fresh, silently (the first save creates it).
- corrupt, unparseable, other schema or kind, or a state the node cannot restore: the file is
  renamed ``<name>.bad-<UTC time>``, the node starts fresh, and its /diagnostics status is
  WARN naming the problem until the node restarts.
- written for another gearbox (ratio or joint names differ): the node refuses to start (one
  line on stderr, exit status 2) and the file is left as it is; with ``state_reset`` true it
  is renamed ``<name>.old-<UTC time>`` and the node starts fresh.

Saves: every ``state_save_period`` seconds (node clock timer) and in ``destroy_node``, which
:func:`gear_phm.nodes.common.run_node` calls after SIGINT/SIGTERM. After kill -9 at most one
period is lost. A failed save is a WARN until the next one succeeds.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from rclpy.node import Node

from gear_phm.nodes.common import ConfigError
from gear_phm.parameters import ParamSpec
from gear_phm.persistence import (identity_difference, load_state, save_state, set_aside,
                                  set_aside_corrupt, StateCorrupt, StateForeign,
                                  StateMismatch)
from gear_phm.status import StatusOut, WARN


def state_parameters(what: str) -> tuple[ParamSpec, ...]:
    """Return the three state parameters of a node whose state is ``what``."""
    return (
        ParamSpec('state_file', '', f'JSON file holding {what} across restarts (empty: not '
                  'persisted); loaded at start, written atomically every state_save_period '
                  'and at shutdown', read_only=True),
        ParamSpec('state_save_period', 10.0, 'the state_file is written this often; kill -9 '
                  'loses at most this much', 's', 0.01, 86400.0, read_only=True),
        ParamSpec('state_reset', False, 'accept a state_file written for another gearbox '
                  '(ratio or joint names): it is kept aside as <name>.old-<UTC time> and the '
                  'node starts fresh (false: the node refuses to start)', read_only=True),
    )


class StateKeeper:
    """Loads and saves one node's ``state_file`` (module docstring).

    ``get_state`` returns (state dict, newest stamp [ns] or None) for a save.
    """

    def __init__(self, node: Node, values: Mapping[str, Any], kind: str,
                 identity: Mapping[str, Any],
                 get_state: Callable[[], tuple[dict[str, Any], int | None]]) -> None:
        self.node = node
        self.path = Path(values['state_file']) if values['state_file'] else None
        self.kind = kind
        self.identity = dict(identity)
        self.reset = bool(values['state_reset'])
        self.period = float(values['state_save_period'])
        self.get_state = get_state
        #: problem at load ('' none), shown as WARN until restart
        self.load_problem = ''
        #: problem of the last save ('' none)
        self.save_problem = ''
        self.saves = 0

    @property
    def enabled(self) -> bool:
        return self.path is not None

    @property
    def problem(self) -> str:
        """'' or what is wrong with the state file, for the node's status message."""
        return '; '.join(p for p in (self.load_problem, self.save_problem) if p)

    def flagged(self, status: StatusOut) -> StatusOut:
        """Return ``status`` raised to WARN with :attr:`problem` appended, if there is one."""
        problem = self.problem
        if not problem:
            return status
        return replace(status, level=max(status.level, WARN),
                       message=f'{status.message}; {problem}')

    def load(self, restore: Callable[[dict[str, Any]], None]) -> bool:
        """Load the file and hand its state to ``restore``; True if a state was restored.

        An identity mismatch (without state_reset) raises :class:`ConfigError`. ``restore``
        raising KeyError/ValueError/TypeError makes the file corrupt (set aside, fresh start).
        """
        if self.path is None:
            return False
        logger = self.node.get_logger()
        try:        # a state file in a new folder: the folder is made now, not at each save
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            msg = f'state file {self.path}: cannot make its folder ({exc})'
            raise ConfigError(msg) from None
        try:
            state = load_state(self.path, self.kind, self.identity, self.reset)
        except (StateMismatch, StateForeign) as exc:
            raise ConfigError(str(exc)) from None
        except StateCorrupt as exc:
            self.load_problem = str(exc)
            logger.warn(self.load_problem)
            return False
        if state is None:
            logger.info(f'no usable state in {self.path}: starting fresh')
            return False
        try:
            restore(state)
        except (KeyError, ValueError, TypeError, IndexError, AttributeError) as exc:
            reason = f'cannot be restored ({type(exc).__name__}: {exc})'
            self.load_problem = str(set_aside_corrupt(self.path, reason))
            logger.warn(self.load_problem)
            return False
        logger.info(f'restored state from {self.path}')
        return True

    def start_timer(self, callback: Callable[[], Any] | None = None) -> None:
        """Call ``callback`` (default :meth:`save`) every ``state_save_period``.

        No timer when state_file is empty.
        """
        if self.path is not None:
            self.node.create_timer(self.period, self.save if callback is None else callback)

    def save(self) -> bool:
        """Write the state now; a failure is kept in ``save_problem`` and logged."""
        if self.path is None:
            return False
        try:
            state, stamp_ns = self.get_state()
            save_state(self.path, self.kind, self.identity, state, stamp_ns)
        except (OSError, ValueError, TypeError) as exc:
            problem = f'state file {self.path} not saved: {" ".join(str(exc).split())}'
            if problem != self.save_problem:
                self.node.get_logger().error(problem)
            self.save_problem = problem
            return False
        self.save_problem = ''
        self.saves += 1
        return True


#: The identity of a state file of many drives (``transmissions``); each drive's own identity
#: (ratio, joints) is kept beside its state, so a drive may be added or removed.
DRIVES_IDENTITY: dict[str, Any] = {'transmissions': True}


def estimator_identity(ratio: float, motor_joint: str, load_joint: str) -> dict[str, Any]:
    """Return what an estimator's state must match: the ratio [-] and the joint names."""
    return {'ratio': float(ratio), 'motor_joint': motor_joint, 'load_joint': load_joint}


def drives_state(parts: Mapping[str, tuple[Mapping[str, Any], dict[str, Any], int | None]]
                 ) -> tuple[dict[str, Any], int | None]:
    """Return (state, newest stamp [ns]) of many drives for :class:`StateKeeper`.

    ``parts``: ``{drive: (identity, state, newest stamp [ns] or None)}``.
    """
    stamps = [stamp for _, _, stamp in parts.values() if stamp is not None]
    return ({'drives': {name: {'identity': dict(identity), 'state': state}
                        for name, (identity, state, _) in parts.items()}},
            max(stamps) if stamps else None)


def drives_restorer(keeper: StateKeeper, identities: Mapping[str, Mapping[str, Any]],
                    restores: Mapping[str, Callable[[dict[str, Any]], None]]
                    ) -> Callable[[dict[str, Any]], None]:
    """Return the ``restore`` of a state of many drives for :meth:`StateKeeper.load`.

    A drive in the file and in the list is restored; a drive new to the list starts fresh and
    one no longer listed is dropped, each with a log line. A drive whose ratio or joints
    changed raises :class:`ConfigError` (the file is kept), or with ``state_reset`` starts
    fresh (the file is kept aside as ``<name>.old-<UTC time>``, the other drives restored).
    """
    def restore(state: dict[str, Any]) -> None:
        saved = state['drives']
        if not isinstance(saved, dict):
            raise TypeError(f'drives is {type(saved).__name__}, not an object')
        logger = keeper.node.get_logger()
        changed = {name: identity_difference(saved[name]['identity'], identity)
                   for name, identity in identities.items() if name in saved}
        changed = {name: why for name, why in changed.items() if why}
        if changed:
            reasons = '; '.join(f'{name}: {why}' for name, why in sorted(changed.items()))
            if not keeper.reset:
                raise ConfigError(f'state file {keeper.path} is for other gearboxes ({reasons}); '
                                  f'set state_reset to true to start these drives fresh (the '
                                  f'file is kept aside)')
            assert keeper.path is not None
            kept = set_aside(keeper.path, 'old')
            logger.warn(f'state file kept as {kept}; starting fresh: {reasons}')
        for name in sorted(set(saved) - set(identities)):
            logger.info(f'state of drive {name} dropped: no longer in transmissions')
        for name in sorted(set(identities) - set(saved)):
            logger.info(f'drive {name} starts fresh: not in {keeper.path}')
        for name in identities:
            if name in saved and name not in changed:
                restores[name](saved[name]['state'])
    return restore
