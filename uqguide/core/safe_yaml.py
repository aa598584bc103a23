"""A YAML loader for configs that cannot be made to explode.

PyYAML's ``safe_load`` still expands aliases without limit (a "billion laughs" document runs for
ever), lets a second ``model:`` key silently replace the first, and recurses once per nesting
level (100k brackets are a RecursionError). A config needs none of that, so this loader refuses
aliases and anchors, a key given twice in one mapping (naming both lines), nesting deeper than
``MAX_DEPTH``, a text over ``MAX_BYTES`` (before parsing) and NUL characters, each as a
:class:`YamlLimitError` (a ``yaml.YAMLError``) with the line and column.
"""

from __future__ import annotations

import re
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, SequenceNode

#: Largest config text accepted (bytes). Real configs are a few kB.
MAX_BYTES = 1_000_000
#: Deepest nesting of mappings and sequences accepted. Real configs nest 4 deep.
MAX_DEPTH = 32


class YamlLimitError(yaml.YAMLError):
    """A document this loader refuses; ``problem`` and ``problem_mark`` say what and where."""

    def __init__(self, problem: str, mark: Any = None) -> None:
        super().__init__(problem)
        self.problem = problem
        self.problem_mark = mark

    def __str__(self) -> str:
        where = (f" at line {self.problem_mark.line + 1}, column {self.problem_mark.column + 1}"
                 if self.problem_mark is not None else "")
        return f"{self.problem}{where}"


class ConfigLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` without aliases, duplicate keys or deep nesting."""

    def __init__(self, stream: Any) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise YamlLimitError(f"alias *{event.anchor} is not allowed in a config (write the "
                                 f"value out)", event.start_mark)
        event = self.peek_event()
        if getattr(event, "anchor", None) is not None:
            raise YamlLimitError(f"anchor &{event.anchor} is not allowed in a config (write the "
                                 f"value out)", event.start_mark)
        nests = self.check_event(yaml.SequenceStartEvent) or self.check_event(
            yaml.MappingStartEvent)
        if nests:
            self._depth += 1
            if self._depth > MAX_DEPTH:
                raise YamlLimitError(f"nested deeper than {MAX_DEPTH} levels", event.start_mark)
        try:
            return super().compose_node(parent, index)
        finally:
            if nests:
                self._depth -= 1

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, Any] = {}
        for key_node, _ in node.value:
            if isinstance(key_node, (MappingNode, SequenceNode)):
                raise YamlLimitError("a key must be a plain value, not a list or mapping",
                                     key_node.start_mark)
            key = self.construct_object(key_node, deep=True)
            if key in seen:
                raise YamlLimitError(
                    f"duplicate key {key!r} (first at line {seen[key].line + 1})",
                    key_node.start_mark)
            seen[key] = key_node.start_mark
        return super().construct_mapping(node, deep=deep)


# YAML 1.2 floats without a dot or an exponent sign (``1e8``, ``1.5e3``): YAML 1.1, and so
# PyYAML, reads them as strings, and ``n_samples: 1e8`` would be refused as "not an integer".
ConfigLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+.0123456789"))


def safe_load(text: str, max_bytes: int = MAX_BYTES) -> Any:
    """Parse one YAML document of at most ``max_bytes`` UTF-8 bytes with :class:`ConfigLoader`;
    YamlLimitError / YAMLError if it is refused or invalid."""
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > max_bytes:
        raise YamlLimitError(f"{size} bytes, more than the {max_bytes} a config may have")
    if "\x00" in text:
        line = text[:text.index("\x00")].count("\n") + 1
        raise YamlLimitError(f"NUL character at line {line}")
    loader = ConfigLoader(text)
    try:
        return loader.get_single_data()
    except RecursionError:
        raise YamlLimitError("nested too deeply") from None
    finally:
        loader.dispose()
