"""gear_phm: health monitoring of mechanical transmissions (friction, efficiency, RUL).

Layout (robot_localization-style split between pure logic and ROS adapters):

- ``gear_phm.models``      physics of the paper (numpy only)
- ``gear_phm.simulation``  seeded transmission plant and duty cycle (numpy only)
- ``gear_phm.estimation``  power-flow classification, efficiency windows, Kalman filter on u
- ``gear_phm.prognostics`` end of life, remaining useful life, prognostic metrics
- ``gear_phm.bagio``       rosbag2/ROS1 reading and rosbag2-MCAP writing (rosbags, mcap)
- ``gear_phm.nodes``       thin rclpy adapters: publisher, estimator, diagnostics
- ``gear_phm.cli``         the ``gear-phm`` command line

Every exception gear_phm raises on purpose derives from :class:`GearPhmError`.
"""

from gear_phm.errors import GearPhmError

__all__ = ['GearPhmError', '__version__']

__version__ = '0.1.0'
