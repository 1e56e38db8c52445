"""One way to specify a parameter: :class:`ParamSpec` (no ROS imports).

Every parameter of gear_phm, of a node, a config dataclass or the CLI, is a ``ParamSpec``:
name, default, description, unit and range (or choices). The same spec declares the ROS
parameter with its ParameterDescriptor (:func:`gear_phm.nodes.common.declare_parameters`),
builds the ``--kebab-case`` CLI option (:mod:`gear_phm.cli.options`), validates values
(:meth:`ParamSpec.check`) and generates the README tables. Cross-field rules live in the
config dataclasses, which call :func:`check_values` first.

A config dataclass declares each parameter once, as a field whose default is :func:`param`
(or :func:`param_from` for a spec shared with other nodes, such as :data:`RATIO`);
:func:`specs_of` reads the specs back from the fields, in field order::

    @dataclass(frozen=True)
    class Config:
        ratio: float = param_from(RATIO, float)
        noise: float = param(0.01, 'std dev of one sample', 'N m', 0.0, 1e6)

    PARAMETERS = specs_of(Config)
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
import math
from typing import TypeVar

Value = bool | int | float | str
#: The type of one parameter's value, fixed by its default.
T = TypeVar('T', bool, int, float, str)
#: The key of a config field's :class:`ParamSpec` in its ``dataclasses.Field.metadata``.
SPEC = 'gear_phm.param'


@dataclass(frozen=True)
class ParamSpec:
    """A named parameter: ``default`` fixes its type (bool, int, float or str).

    ``low``/``high`` are inclusive bounds of a number (None: unbounded); ``choices`` the
    allowed strings; ``unit`` is SI ('-' dimensionless, '' for text and flags);
    ``read_only`` parameters are fixed once a node has started. A float parameter with a
    non-empty ``nan_means`` also accepts NaN, which stands for that text (e.g. a value derived
    from another parameter); its ROS declaration then carries the range as a constraint, since
    a FloatingPointRange refuses NaN.
    """

    name: str
    default: Value
    description: str
    unit: str = ''
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    read_only: bool = False
    nan_means: str = ''

    @property
    def kind(self) -> type:
        """bool, int, float or str."""
        return type(self.default)

    @property
    def text(self) -> str:
        """Return the description with its unit, e.g. ``prior std dev of u [-]``."""
        return f'{self.description} [{self.unit}]' if self.unit else self.description

    def check(self, value: object) -> Value:
        """Return ``value`` converted to this parameter's type (an int is a float).

        Raises ValueError naming the parameter, the rule and the value.
        """
        kind = self.kind
        if kind is bool:
            if not isinstance(value, bool):
                raise ValueError(f'{self.name} must be true or false, got {value!r}')
            return value
        if kind is str:
            if not isinstance(value, str):
                raise ValueError(f'{self.name} must be a string, got {value!r}')
            if self.choices and value not in self.choices:
                allowed = ', '.join(choice or '""' for choice in self.choices)
                raise ValueError(f'{self.name} must be one of {allowed}, got {value!r}')
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            unit = f' [{self.unit}]' if self.unit else ''
            raise ValueError(f'{self.name} must be a number{unit}, got {value!r}')
        if kind is float and self.nan_means and math.isnan(value):
            return math.nan
        if kind is int and int(value) != value:
            raise ValueError(f'{self.name} must be an integer, got {value!r}')
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        if math.isnan(value) or not low <= value <= high:
            unit = '' if self.unit in ('', '-') else f' {self.unit}'
            if self.high is None:
                rule = f'>= {low:g}{unit}'
            elif self.low is None:
                rule = f'<= {high:g}{unit}'
            else:
                rule = f'in [{low:g}, {high:g}]{unit}'
            raise ValueError(f'{self.name} must be {rule}, got {value!r}')
        return int(value) if kind is int else float(value)

    def parse(self, text: str) -> Value:
        """Parse a command-line or YAML string as this parameter's type, checked."""
        kind = self.kind
        try:
            if kind is bool:
                lowered = text.strip().lower()
                if lowered not in ('true', 'false', '1', '0'):
                    raise ValueError
                value: Value = lowered in ('true', '1')
            elif kind is int:
                value = int(text)
            elif kind is float:
                value = float(text)
            else:
                value = text
        except ValueError:
            what = {bool: 'true or false', int: 'an integer', float: 'a number'}[kind]
            raise ValueError(f'{self.name} needs {what}, got {text!r}') from None
        return self.check(value)


def spec_map(specs: Iterable[ParamSpec]) -> dict[str, ParamSpec]:
    """``{name: spec}``; ValueError on a name given twice."""
    table: dict[str, ParamSpec] = {}
    for spec in specs:
        if spec.name in table:
            raise ValueError(f'parameter {spec.name} is specified twice')
        table[spec.name] = spec
    return table


def check_values(specs: Iterable[ParamSpec], values: Mapping[str, object]) -> dict[str, Value]:
    """Check each value of ``values`` by the spec of its name.

    Raises ValueError on an unknown name or a bad value.
    """
    table = spec_map(specs)
    unknown = sorted(set(values) - set(table))
    if unknown:
        raise ValueError(f'unknown parameter(s) {unknown}; known: {sorted(table)}')
    return {name: table[name].check(value) for name, value in values.items()}


def read_only_changes(specs: Iterable[ParamSpec], old: Mapping[str, object],
                      new: Mapping[str, object]) -> list[str]:
    """Return the names of the read-only specs whose value differs from ``old`` to ``new``.

    A name absent from either mapping is skipped; NaN equals NaN.
    """
    changed = []
    for spec in specs:
        if not spec.read_only or spec.name not in old or spec.name not in new:
            continue
        a, b = old[spec.name], new[spec.name]
        if a != b and not (isinstance(a, float) and isinstance(b, float)
                           and math.isnan(a) and math.isnan(b)):
            changed.append(spec.name)
    return changed


def refuse_read_only_changes(specs: Iterable[ParamSpec], old: Mapping[str, object],
                             new: Mapping[str, object], instead: str) -> None:
    """Raise ValueError naming the read-only specs that differ (:func:`read_only_changes`).

    ``instead``: what to do instead, e.g. 'start a new pipeline'.
    """
    changed = read_only_changes(specs, old, new)
    if changed:
        msg = (f'cannot reconfigure {", ".join(changed)}: the learned state depends on '
               f'{"them" if len(changed) > 1 else "it"}; {instead}')
        raise ValueError(msg) from None


def defaults(specs: Iterable[ParamSpec]) -> dict[str, Value]:
    """``{name: default}``."""
    return {spec.name: spec.default for spec in specs}


def param(default: T, description: str, unit: str = '', low: float | None = None,
          high: float | None = None, *, choices: tuple[str, ...] = (), read_only: bool = False,
          nan_means: str = '') -> T:
    """Declare a config dataclass field and its :class:`ParamSpec` (named after the field).

    The arguments are those of ParamSpec without the name. Typed as the default, so that
    ``x: float = param(0.5, ...)`` type-checks; at run time it is the ``dataclasses.field``
    whose metadata holds the spec, read back by :func:`specs_of`.
    """
    spec = ParamSpec('', default, description, unit, low, high, choices, read_only, nan_means)
    return param_from(spec, type(default))


def param_from(spec: ParamSpec, kind: type[T]) -> T:
    """Declare a config dataclass field by a spec shared with others (e.g. :data:`RATIO`).

    ``kind`` is the type of the spec's default (the field's type, for the type checker).
    Raises TypeError when the default is not of that type. A field of another name than the
    spec's is that spec renamed.
    """
    default = spec.default
    if type(default) is not kind:
        msg = f'parameter {spec.name}: default {default!r} is not of type {kind.__name__}'
        raise TypeError(msg) from None
    held: T = field(default=default, metadata={SPEC: spec})
    return held


def specs_of(config: type) -> tuple[ParamSpec, ...]:
    """Return the :class:`ParamSpec` of each field of dataclass ``config``, in field order.

    Each spec is named after its field. Raises TypeError on a field not declared by
    :func:`param` or :func:`param_from`, or whose annotation is not its default's type.
    """
    specs = []
    for item in fields(config):
        spec = item.metadata.get(SPEC)
        if not isinstance(spec, ParamSpec):
            msg = f'{config.__name__}.{item.name} is not declared by param() or param_from()'
            raise TypeError(msg) from None
        kind = spec.kind
        if item.type not in (kind, kind.__name__):
            msg = (f'{config.__name__}.{item.name} is annotated {item.type!r} but its default '
                   f'{spec.default!r} is of type {kind.__name__}')
            raise TypeError(msg) from None
        specs.append(spec if spec.name == item.name else replace(spec, name=item.name))
    return tuple(specs)


#: The gearbox ratio, one parameter of the simulation (publisher), the estimator and the
#: diagnostics alike: they must agree on it. Finite and positive; the bounds are those of a
#: ratio the float arithmetic of eqs 10/12 handles (u/R and R u stay far from overflow).
#: Read-only: the learned state (u, the RUL history) and the state file belong to one ratio.
RATIO = ParamSpec('ratio', 3.0, 'ideal torque gain load/motor R = z2/z1 of the gearbox', '-',
                  1e-6, 1e6, read_only=True)
#: The joints' names in the JointState messages: the publisher's, the estimator's and
#: ``gear-phm analyze``/``simulate``'s. Read-only: they name what the state was learned from.
MOTOR_JOINT = ParamSpec('motor_joint', 'motor', 'name of the motor joint in the JointState '
                        'messages', read_only=True)
LOAD_JOINT = ParamSpec('load_joint', 'load', 'name of the load joint in the JointState '
                       'messages', read_only=True)
#: The /diagnostics status of the health: the diagnostics node's and ``gear-phm analyze``'s
#: (whose option for ``rate`` is ``--diagnostics-rate``).
TRANSMISSION_NAME = ParamSpec('transmission_name', 'gearbox',
                              'status name is "gear_phm: <transmission_name>"')
HARDWARE_ID = ParamSpec('hardware_id', '', 'hardware_id of the /diagnostics status (empty: '
                        "the transmission_name, the drive's name)")
DIAGNOSTICS_RATE = ParamSpec('rate', 1.0, '/diagnostics publishing rate', 'Hz', 0.01, 1000.0,
                             read_only=True)
#: ``gear-phm analyze``'s time of a sample (the nodes always take header.stamp).
STAMP_SOURCE = ParamSpec('stamp_source', 'header', "time of each sample: 'header' (the "
                         "JointState's header.stamp, as the nodes) or 'log' (the bag's record "
                         'time, for a publisher that leaves header.stamp unset)',
                         choices=('header', 'log'))
