"""The names of one drive's outputs: its topics, statuses, plot file and messages.

The single transmission and a drive of a ``transmissions`` list differ only in names: the
single one publishes today's topics (``gear_phm/friction``) and statuses (``gear_phm:
<transmission_name>``), a drive of a list its own (``gear_phm/<drive>/friction``,
``gear_phm: <drive>``). Code that runs a drive reads its names here and never asks which
kind it runs: one transmission is a list of one, named by :meth:`DriveNames.single`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from gear_phm.interfaces import drive_topic
from gear_phm.parameters import HARDWARE_ID, TRANSMISSION_NAME

#: The estimator status's name of the single transmission in ``gear-phm analyze``'s output.
ESTIMATOR_STATUS_NAME = 'gear_phm estimator: estimator'


def same_topic(topic: str) -> str:
    """Return ``topic`` itself: the single transmission's topics are today's names."""
    return topic


@dataclass(frozen=True)
class DriveTopic:
    """A listed drive's topics: ``gear_phm/friction`` -> ``gear_phm/<drive>/friction``."""

    drive: str

    def __call__(self, topic: str) -> str:
        """Return the drive's own ``topic`` (:func:`gear_phm.interfaces.drive_topic`)."""
        return drive_topic(self.drive, topic)


@dataclass(frozen=True)
class DriveNames:
    """How one drive names its outputs and speaks of itself (module docstring)."""

    #: the drive's name in a summary's ``transmissions`` and a plot's title ('' alone)
    drive: str
    #: the health status is ``gear_phm: <transmission_name>``, with this hardware_id
    transmission_name: str
    hardware_id: str
    #: the estimator status's name
    estimator_status: str
    #: the drive's topic of a single transmission's topic (picklable: workers get it)
    topic: Callable[[str], str]
    #: the end of the names of the drive's files ('' alone, '_<name>' of a list)
    file_suffix: str
    #: the start of a message about this drive ('drive <name>: '; '' alone)
    label: str
    #: the drive named beside a message about it (' (drive <name>)'; '' alone)
    aside: str
    #: where the user gives the ratio
    ratio_where: str
    #: where the user gives parameter ``{0}`` the value ``{1}`` (a format string)
    param_where: str
    #: one drive of a ``transmissions`` list (its stream is read in joined batches)
    listed: bool

    @classmethod
    def single(cls, transmission_name: str = str(TRANSMISSION_NAME.default),
               hardware_id: str = str(HARDWARE_ID.default),
               estimator_status: str = ESTIMATOR_STATUS_NAME) -> DriveNames:
        """Return the names of the single transmission (the global parameters)."""
        return cls('', transmission_name, hardware_id, estimator_status, same_topic,
                   '', '', '', '--ratio', '--param {0}={1}', False)

    @classmethod
    def of(cls, drive: str) -> DriveNames:
        """Return the names of drive ``drive`` of a ``transmissions`` list."""
        entry = f'in the entry of drive {drive}'
        return cls(drive, drive, drive, f'gear_phm estimator: {drive}',
                   DriveTopic(drive), f'_{drive}', f'drive {drive}: ',
                   f' (drive {drive})', f'the ratio {entry}', f'{{0}}: {{1}} {entry}', True)

    @classmethod
    def chosen(cls, drive: str | None) -> DriveNames:
        """Return the names of an optional drive: ``drive`` of a list, or (None) the single one.

        The one place where a user's optional drive name (``gear-phm evaluate --drive``) becomes
        a drive's names.
        """
        return cls.single() if drive is None else cls.of(drive)

    @property
    def plot_file(self) -> str:
        """Return the plot's file name in the output directory."""
        return f'analysis{self.file_suffix}.png'
