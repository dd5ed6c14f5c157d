"""Typed option schemas: dataclasses whose fields carry a type (checked by OmegaConf) and, where a
type is not enough, a `Rule` (a range, a choice). Every bad value becomes one ConfigError
sentence, "policy.k must be an integer >= 1, not 0", naming the dotted key, what is allowed
and the value.

The run config's own schema is xicm.core.assembly.config_schema; a plugin passes its options' schema to
`register(name, factory, options=Dataclass)` and xicm.core.assembly.plugins checks a group against it
with `check_options`. Union types do not exist in OmegaConf 2.3: such a field is `Any` and its
rule checks the type itself (`number`, `rule(...)` with its own test).
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import types
import typing
from dataclasses import dataclass
from typing import Any, Callable, Collection, Iterable, Mapping

from omegaconf import MISSING, DictConfig, ListConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from xicm.core.contracts.errors import ConfigError

RULE = "xicm_rule"  # the dataclass field metadata key of a Rule
HOW = "xicm_how"  # field metadata key: the option says how a run is done, not what it measures
UNIONS = (typing.Union, types.UnionType)  # Optional[int] and int | None


@dataclass(frozen=True)
class Rule:
    """What a field allows beyond its type: `test(value)` and the words for it, where `{type}`
    stands for the field type's words ("{type} >= 1" -> "an integer >= 1")."""

    test: Callable[[Any], bool]
    words: str


def rule(test: Callable[[Any], bool], words: str) -> dict[str, Rule]:
    """Field metadata: `field(default=..., metadata=rule(test, words))`."""
    return {RULE: Rule(test, words)}


def at_least(low: float) -> dict[str, Rule]:
    return rule(lambda v: v >= low, f"{{type}} >= {low}")


def above(low: float) -> dict[str, Rule]:
    return rule(lambda v: v > low, f"{{type}} > {low}")


def between(low: float, high: float) -> dict[str, Rule]:
    return rule(lambda v: low <= v <= high, f"{{type}} from {low} to {high}")


def one_of(*choices: str) -> dict[str, Rule]:
    return rule(lambda v: v in choices, "one of " + ", ".join(choices))


def how(metadata: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Field metadata for an option that changes how a run is done (threads, slots, timeouts,
    where files are kept), not what it measures: it stays outside the run's identity, so a run
    resumes under another value (`field(default=2, metadata=how(at_least(1)))`)."""
    return {**(metadata or {}), HOW: True}


def how_fields(schema: type) -> list[str]:
    """The names of a schema's fields marked with `how`."""
    return [f.name for f in dataclasses.fields(schema) if f.metadata.get(HOW)]


def is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def number(low: float, *, strict: bool = False) -> dict[str, Rule]:
    """For an `Any` field holding an int or a float (OmegaConf has no Union): > low, or >= low."""
    if strict:
        return rule(lambda v: is_number(v) and v > low, f"a number > {low}")
    return rule(lambda v: is_number(v) and v >= low, f"a number >= {low}")


# ------------------------------------------------------------------ words and values
_WORDS = {int: ("an integer", "integers"), float: ("a number", "numbers"), bool: ("true or false", "true/false values"),
          str: ("a string", "strings")}


def type_words(tp: Any, plural: bool = False) -> str:
    """'an integer', 'a list of strings', 'an integer or null', ... for an annotation."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in UNIONS:
        inner = [a for a in args if a is not type(None)]
        return f"{type_words(inner[0], plural)} or null" if len(inner) == 1 else "values" if plural else "a value"
    if origin in (list, tuple):
        return "a list of " + (type_words(args[0], plural=True) if args else "values")
    if origin is dict:
        return "mappings" if plural else "a mapping"
    words = _WORDS.get(tp, ("a value", "values"))
    return words[plural]


def allowed_words(field: dataclasses.Field, tp: Any) -> str:
    found = field.metadata.get(RULE)
    base = type_words(_without_none(tp))
    words = base if found is None else found.words.replace("{type}", base)
    return f"{words} or null" if _is_optional(tp) else words


def shown(value: Any) -> str:
    """A value as the user wrote it: strings quoted, lists in brackets, null/true/false."""
    if isinstance(value, (DictConfig, ListConfig)):
        value = OmegaConf.to_container(value)
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(shown(v) for v in value) + "]"
    return json.dumps(value, default=str)


def _is_optional(tp: Any) -> bool:
    return typing.get_origin(tp) in UNIONS and type(None) in typing.get_args(tp)


def _without_none(tp: Any) -> Any:
    if _is_optional(tp):
        inner = [a for a in typing.get_args(tp) if a is not type(None)]
        return inner[0] if len(inner) == 1 else Any
    return tp


def _fields(schema: type) -> dict[str, tuple[dataclasses.Field, Any]]:
    hints = typing.get_type_hints(schema)
    return {f.name: (f, hints[f.name]) for f in dataclasses.fields(schema)}


def bad_value(key: str, field: dataclasses.Field, tp: Any, value: Any) -> ConfigError:
    return ConfigError(f"{key} must be {allowed_words(field, tp)}, not {shown(value)}")


# ------------------------------------------------------------------ checks
def check_value(key: str, field: dataclasses.Field, tp: Any, value: Any) -> Any:
    """`value` converted to the field's type (OmegaConf's conversion), or ConfigError; then its rule."""
    holder = OmegaConf.structured(dataclasses.make_dataclass("Holder", [("value", tp, dataclasses.field(default=MISSING))]))
    try:
        holder.value = value
        converted = OmegaConf.to_container(holder)["value"]
    except OmegaConfBaseException:
        raise bad_value(key, field, tp, value) from None
    found = field.metadata.get(RULE)
    if found is not None and converted is not None and not found.test(converted):
        raise bad_value(key, field, tp, value)
    return converted


def check_options(values: Mapping[str, Any], schema: type, prefix: str, owner: str) -> None:
    """Check a plugin's options (resolved, without `name`) against its schema.

    Unknown keys, values of the wrong type, values outside a field's rule and required fields
    (no default) left unset each raise ConfigError with one sentence naming `prefix.key`.
    """
    fields = _fields(schema)
    unknown = [k for k in values if k not in fields]
    if unknown:
        names = ", ".join(f"{prefix}.{k}" for k in unknown)
        raise ConfigError(
            f"unknown option{'s' if len(unknown) > 1 else ''} {names} of {owner}; available: {', '.join(fields) or 'none'}"
        )
    for name, (field, tp) in fields.items():
        if name in values:
            check_value(f"{prefix}.{name}", field, tp, values[name])
        elif field.default in (MISSING, dataclasses.MISSING) and field.default_factory is dataclasses.MISSING:
            raise ConfigError(f"{prefix}.{name} must be set to {allowed_words(field, tp)}; {owner} has no default for it")


def check_config(cfg: DictConfig, schema: type, prefix: str = "") -> None:
    """Check the rules of a composed config's typed keys (Hydra already checked their types).

    Only keys with a rule and nested schemas are read (so interpolations of other keys, such as
    run_name's `${hydra:...}`, need not resolve here); `Any`/mapping keys holding a plugin's
    options are checked against that plugin's schema instead (Registry.check_options).
    """
    for name, (field, tp) in _fields(schema).items():
        if name not in cfg:
            continue
        key = f"{prefix}{name}"
        if dataclasses.is_dataclass(tp):
            check_config(cfg[name], tp, prefix=f"{key}.")
        elif RULE in field.metadata:
            check_value(key, field, tp, cfg[name])


def leaf_field(schema: type, key: str) -> tuple[dataclasses.Field, Any] | None:
    """The field a dotted key names if it is a value, None if it is a nested schema or lies in a
    plugin's mapping (whose keys the plugin's schema knows); ConfigError if the schema has no such key."""
    parts = key.split(".")
    for depth, part in enumerate(parts):
        fields = _fields(schema)
        if part not in fields:
            guess = difflib.get_close_matches(part, fields, n=1)
            where = ".".join(parts[:depth]) or "the config"
            hint = f" (did you mean {'.'.join([*parts[:depth], guess[0]])}?)" if guess else ""
            raise ConfigError(f"unknown key {key}{hint}; {where} has: {', '.join(fields)}")
        _, tp = fields[part]
        if not dataclasses.is_dataclass(tp):
            return fields[part] if depth == len(parts) - 1 and typing.get_origin(tp) is not dict else None
        schema = tp
    return None


def check_overrides(args: Iterable[str], schema: type, groups: Collection[str] = ()) -> None:
    """Check the command line's values of a schema's keys before Hydra composes.

    Hydra would reject a value of the wrong type too, but in four lines without saying what is
    allowed; this gives the one sentence (also for each value of a `-m` sweep, and for a key the
    schema does not have). Anything else (flags, group choices, `+`/`~`, `hydra.*`, keys inside a
    plugin's options, interpolations, malformed overrides, a config group the config does not
    choose, e.g. `experiment=x` for `+experiment=x`: `groups`) is left to Hydra.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.core.override_parser.types import QuotedString
    from hydra.errors import HydraException

    parser = OverridesParser.create()
    for arg in args:
        try:
            override = parser.parse_override(arg)
        except HydraException:
            continue
        if override.is_delete() or override.is_add() or override.package is not None or override.is_hydra_override():
            continue
        if override.key_or_group.split(".")[0] in groups and override.key_or_group.split(".")[0] not in _fields(schema):
            continue
        found = leaf_field(schema, override.key_or_group)
        if found is None:
            continue
        if override.is_discrete_sweep():
            values = list(override.sweep_iterator())
        elif override.is_sweep_override():
            continue
        else:
            values = [override.value()]
        for value in values:
            value = _plain(value, QuotedString)
            if not (isinstance(value, str) and "${" in value):
                check_value(override.key_or_group, *found, value)


def _plain(value: Any, quoted: type) -> Any:
    if isinstance(value, quoted):
        return value.text
    if isinstance(value, list):
        return [_plain(v, quoted) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v, quoted) for k, v in value.items()}
    return value
