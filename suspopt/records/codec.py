"""Records as JSON and back: every record is a dataclass whose fields are plain values,
other records, enums, or tuples, lists and string-keyed dicts of them.

:class:`Record` gives each one ``to_json()`` (plain data, what ``json.dump`` takes) and
``from_json(data, where)``, which reads the fields by their type hints and validates
them: a missing key or a value of the wrong type is a
:class:`~suspopt.errors.ConfigError` naming the file and the key
(``run/study.json: steps.low.iterations: expected an integer, got 'x'``) — the user's file
is damaged. Nothing else is turned into that error.

A *document* record (one file of a run directory) has a ``KIND``; its JSON carries
``kind`` and ``format`` (:data:`FORMAT`), checked when it is read.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import types
import typing
from collections.abc import Mapping
from typing import Any, ClassVar, Self

from suspopt.errors import ConfigError

#: the format of every record written; a reader refuses another
FORMAT = 1


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + '...'


class Node:
    """A JSON value being read, with where it is: ``file`` and the dotted ``key``."""

    __slots__ = ('value', 'file', 'key')

    def __init__(self, value: Any, file: str = '', key: str = ''):
        self.value, self.file, self.key = value, file, key

    def error(self, problem: str) -> ConfigError:
        where = ': '.join(x for x in (self.file, self.key) if x)
        return ConfigError(f'{where}: {problem}' if where else problem)

    def child(self, name: str | int) -> Node:
        key = f'{self.key}[{name}]' if isinstance(name, int) else f'{self.key}.{name}'
        return Node(None, self.file, key.lstrip('.'))

    def object(self) -> dict[str, Any]:
        if not isinstance(self.value, dict):
            raise self.error(f'expected a JSON object, got {_show(self.value)}')
        return self.value

    def get(self, name: str) -> Node:
        """The member ``name`` (a ConfigError naming it if missing)."""
        data = self.object()
        node = self.child(name)
        if name not in data:
            raise node.error('missing')
        node.value = data[name]
        return node

    def members(self) -> list[tuple[str, Node]]:
        out = []
        for k, v in self.object().items():
            node = self.child(k)
            node.value = v
            out.append((k, node))
        return out

    def opt(self, name: str) -> Node | None:
        """The member ``name``, or None if it is missing or null."""
        data = self.object()
        if data.get(name) is None:
            return None
        return self.get(name)

    def number(self) -> float:
        return float(_decode(float, self))

    def text(self) -> str:
        return str(_decode(str, self))

    def items(self) -> list[Node]:
        if not isinstance(self.value, list):
            raise self.error(f'expected a list, got {_show(self.value)}')
        out = []
        for i, v in enumerate(self.value):
            node = self.child(i)
            node.value = v
            out.append(node)
        return out


# ---------------------------------------------------------------------------- decoding
def _decode(hint: Any, node: Node) -> Any:
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    value = node.value
    if hint is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        return _decode(inner, node)
    if origin is dict:
        return {k: _decode(args[1], v) for k, v in node.members()}
    if origin is tuple:
        items = node.items()
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_decode(args[0], v) for v in items)
        if len(items) != len(args):
            raise node.error(f'expected a list of {len(args)}, got {_show(node.value)}')
        return tuple(_decode(a, v) for a, v in zip(args, items))
    if origin is list:
        return [_decode(args[0], v) for v in node.items()]
    if isinstance(hint, type) and issubclass(hint, Record):
        return hint.from_json(node)
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        try:
            return hint(value)
        except ValueError:
            allowed = ', '.join(repr(m.value) for m in hint)
            raise node.error(f'expected one of {allowed}, got {_show(value)}') from None
    if hint is bool:
        if not isinstance(value, bool):
            raise node.error(f'expected true or false, got {_show(value)}')
        return value
    if hint is int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise node.error(f'expected an integer, got {_show(value)}')
        return value
    if hint is float:
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise node.error(f'expected a number, got {_show(value)}')
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise node.error(f'expected a string, got {_show(value)}')
        return value
    raise TypeError(f'a record field of type {hint!r} cannot be read')  # a bug, not input


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


# ---------------------------------------------------------------------------- encoding
def encode(value: Any) -> Any:
    """Plain JSON data of a record field's value."""
    if isinstance(value, Record):
        return value.to_json()
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, Mapping):
        return {str(k): encode(v) for k, v in value.items()}
    if isinstance(value, (tuple, list)):
        return [encode(v) for v in value]
    return value


class Record:
    """Base of every record (a dataclass): ``to_json`` / ``from_json`` by its fields.

    A field with ``metadata={'json': False}`` is not written (and must have a default);
    one with ``metadata={'omit_none': True}`` is not written while it is None.
    ``derived()`` adds keys to the JSON that are computed from the fields, for the
    reader's convenience (they are not read back)."""

    KIND: ClassVar[str | None] = None

    def derived(self) -> dict[str, Any]:
        return {}

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {'kind': self.KIND, 'format': FORMAT} if self.KIND else {}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if f.metadata.get('json', True) and not (
                value is None and f.metadata.get('omit_none', False)
            ):
                out[f.name] = encode(value)
        out.update({k: encode(v) for k, v in self.derived().items()})
        return out

    @classmethod
    def from_json(cls, data: Any, file: str = '') -> Self:
        """The record of ``data`` (plain JSON data, or a :class:`Node` of it); ``file``
        names where it was read for the error messages."""
        node = data if isinstance(data, Node) else Node(data, file)
        obj = node.object()
        if cls.KIND is not None and 'kind' in obj:
            _check_kind(cls.KIND, node)
        hints = _hints(typing.cast(type, cls))
        kwargs = {}
        for f in dataclasses.fields(cls):  # type: ignore[arg-type]
            if not f.metadata.get('json', True):
                continue
            if f.name not in obj and (
                f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
            ):
                continue
            kwargs[f.name] = _decode(hints[f.name], node.get(f.name))
        record = cls(**kwargs)
        record.check(node)
        return record

    def check(self, node: Node) -> None:
        """Further consistency of a record just read (a ConfigError from ``node`` if not)."""


def _check_kind(kind: str, node: Node) -> None:
    got = node.get('kind').value
    if got != kind:
        raise node.child('kind').error(f'expected {kind!r}, got {_show(got)}')
    fmt = node.get('format')
    if fmt.value != FORMAT:
        raise fmt.error(
            f'format {_show(fmt.value)} is not the format {FORMAT} of this suspopt '
            '(written by another version; re-run it with this one)'
        )


def read_document(cls: type[Record], data: Any, file: str) -> Record:
    """A document record (it has a ``KIND``) from the plain data of its file: ``kind`` and
    ``format`` are required."""
    node = Node(data, file)
    node.get('kind')
    return cls.from_json(node)
