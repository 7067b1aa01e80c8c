"""An XML element tree that remembers line numbers (the standard library's ElementTree
drops them), for loaders whose every message must name file and line.

Built with expat. A malformed file raises SceneError at the line expat reports.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from ..errors import SceneError


@dataclass
class Node:
    tag: str
    attrs: dict
    line: int
    path: Path
    children: list["Node"] = field(default_factory=list)

    def get(self, key: str, default=None):
        return self.attrs.get(key, default)

    @property
    def where(self) -> tuple[Path, int]:
        return self.path, self.line


def parse_xml(path: Path) -> Node:
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise SceneError(f"cannot read file ({e.strerror})", path) from None
    parser = expat.ParserCreate()
    root: list[Node] = []
    stack: list[Node] = []

    def start(tag, attrs):
        node = Node(tag, dict(attrs), parser.CurrentLineNumber, path)
        if stack:
            stack[-1].children.append(node)
        else:
            root.append(node)
        stack.append(node)

    def end(tag):
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as e:
        raise SceneError(f"XML syntax error: {expat.ErrorString(e.code)} (column {e.offset + 1})",
                         path, e.lineno) from None
    if not root:
        raise SceneError("the file has no XML element", path)
    return root[0]
