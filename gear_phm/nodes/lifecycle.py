"""Managed (lifecycle) nodes: the estimator and the diagnostics node are ``LifecycleNode``.

The states and transitions are ROS 2's (``lifecycle_msgs``; served by
:class:`rclpy.lifecycle.LifecycleNode` as ``~/change_state``, ``~/get_state``, ...):

- unconfigured (after construction): the parameters are declared; nothing else exists.
- configure: the parameters are validated as a whole (a problem fails the transition with
  one logged line; the node stays unconfigured), the state file is loaded, publishers,
  services and timers are made. The node is then inactive.
- inactive: nothing is published (every output is a lifecycle publisher, disabled), no
  subscription exists, no timer runs; ``/diagnostics`` too is silent, as in nav2 (an
  inactive node is not running; ``~/get_state`` tells its state).
- activate: the subscriptions are made, the timers start, the publishers are enabled, the
  recording (diagnostics node) writes.
- deactivate: the buffered input is processed and published, the subscriptions go, the
  timers stop, the state file is written and the recording's file is closed (summary,
  footer, metadata.yaml: a complete bag that rosbags and mcap's reader read; a later
  activate records into the bag's next file, ``<name>_<k>.mcap``).
- cleanup: what configure made is destroyed (back to unconfigured); shutdown (from any
  state): as deactivate, then cleanup.

``autostart`` (default true, as robot_localization and nav2's ``autostart``): the node
configures and activates itself at construction, so ``ros2 run``, ``gear-phm monitor`` and
the launch files behave as before; a configure that fails there raises
:class:`~gear_phm.nodes.common.ConfigError` (one line on stderr, exit status 2).

The bookkeeping is generic (:class:`ManagedNode`): while configuring, every publisher made
through ``create_publisher`` is a lifecycle publisher, and every ``create_subscription`` is
kept as a recipe that activate carries out and deactivate undoes; the node's timers (all made
by configure or later) running at the end of configure or at deactivate are paused and resumed
at activate; the parameter callbacks added while configuring are removed at cleanup. So the
node code and the transport build their entities as a plain node does.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn

from gear_phm.nodes.common import check_overrides, ConfigError
from gear_phm.parameters import ParamSpec

#: Configure and activate at construction (module docstring).
AUTOSTART = ParamSpec('autostart', True, 'configure and activate at start (false: stay '
                      'unconfigured until a lifecycle_msgs ChangeState request)',
                      read_only=True)

SUCCESS = TransitionCallbackReturn.SUCCESS
FAILURE = TransitionCallbackReturn.FAILURE


class ManagedNode(LifecycleNode):
    """A LifecycleNode whose subclass implements :meth:`configure` and the hooks below.

    ``configure()`` builds the node (raises ConfigError on invalid parameters);
    ``deactivating()`` processes buffers and saves; ``cleaning_up()`` drops what configure
    made beyond publishers, timers, services and subscriptions (which go here).
    """

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self._configuring = False
        self._autostarting = False
        self.configured = False
        self.active = False
        self.config_error = ''
        self._recipes: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
        self._live: list[Any] = []              # subscriptions while active
        self._paused: list[Any] = []            # timers to resume at activate
        self._made: list[tuple[Callable[[Any], Any], Any]] = []    # (destroy, entity)

    def autostart(self) -> None:
        """Configure and activate now; raises ConfigError if configure fails.

        The reason is then not logged: :func:`~gear_phm.nodes.common.run_node` prints it as the
        one line on stderr.
        """
        self._autostarting = True
        configured = self.trigger_configure()
        self._autostarting = False
        if configured != SUCCESS:
            raise ConfigError(self.config_error or f'{self.get_name()}: configure failed')
        if self.trigger_activate() != SUCCESS:
            raise ConfigError(f'{self.get_name()}: activate failed')

    # -- hooks of the subclass --------------------------------------------------------------
    def configure(self) -> None:
        """Validate the parameters and build the node; raises ConfigError."""

    def activating(self) -> None:
        """After the subscriptions are made, before the publishers are enabled."""

    def deactivating(self) -> None:
        """Before the subscriptions go: process what is buffered, save the state."""

    def cleaning_up(self) -> None:
        """Drop what :meth:`configure` made (the entities are destroyed after this)."""

    # -- entity bookkeeping -----------------------------------------------------------------
    def create_publisher(self, *args: Any, **kwargs: Any) -> Any:
        """Make a lifecycle publisher while configuring, a plain one otherwise (rclpy's own)."""
        if getattr(self, '_configuring', False):
            publisher = self.create_lifecycle_publisher(*args, **kwargs)
            self._made.append((self.destroy_lifecycle_publisher, publisher))
            return publisher
        return super().create_publisher(*args, **kwargs)

    def create_subscription(self, *args: Any, **kwargs: Any) -> Any:
        """Keep the subscription as a recipe made at activate, while configuring (None)."""
        if getattr(self, '_configuring', False):
            self._recipes.append((args, kwargs))
            return None
        return super().create_subscription(*args, **kwargs)

    def create_service(self, *args: Any, **kwargs: Any) -> Any:
        service = super().create_service(*args, **kwargs)
        if getattr(self, '_configuring', False):
            self._made.append((self.destroy_service, service))
        return service

    def add_on_set_parameters_callback(self, callback: Any) -> None:
        super().add_on_set_parameters_callback(callback)
        if getattr(self, '_configuring', False):
            self._made.append((self.remove_on_set_parameters_callback, callback))

    def add_post_set_parameters_callback(self, callback: Any) -> None:
        super().add_post_set_parameters_callback(callback)
        if getattr(self, '_configuring', False):
            self._made.append((self.remove_post_set_parameters_callback, callback))

    def _pause_timers(self) -> None:
        """Cancel the node's running timers (all are configure's) and keep them to resume."""
        for timer in list(self.timers):
            if not timer.is_canceled():
                timer.cancel()
                self._paused.append(timer)

    # -- transitions ------------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._configuring = True
        try:
            check_overrides(self)
            self.configure()
        except ConfigError as exc:
            self.config_error = str(exc)
            if not self._autostarting:
                self.get_logger().error(f'configure failed: {exc}')
            self._configuring = False
            self._destroy_made()
            return FAILURE
        finally:
            self._configuring = False
        self.configured = True
        self._pause_timers()
        return super().on_configure(state)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._live = [super(ManagedNode, self).create_subscription(*args, **kwargs)
                      for args, kwargs in self._recipes]
        for timer in self._paused:
            timer.reset()
        self._paused = []
        self.activating()
        self.active = True
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._stop()
        return super().on_deactivate(state)

    def _stop(self) -> None:
        """Deactivate's work: the hook (still publishing), no subscriptions, timers paused."""
        if not self.active:
            return
        for subscription in self._live:
            self.destroy_subscription(subscription)
        self._live = []
        self.deactivating()
        self._pause_timers()
        self.active = False

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._cleanup()
        return super().on_cleanup(state)

    def _cleanup(self) -> None:
        if not self.configured:
            return
        self.cleaning_up()
        self._destroy_made()
        self.configured = False

    def _destroy_made(self) -> None:
        for destroy, entity in reversed(self._made):
            destroy(entity)
        for timer in list(self.timers):
            self.destroy_timer(timer)
        self._made, self._recipes, self._paused = [], [], []

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """From any state: deactivate's work, then cleanup's."""
        self._stop()
        self._cleanup()
        return super().on_shutdown(state)
