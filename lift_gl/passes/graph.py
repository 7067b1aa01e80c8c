"""The frame as a graph of passes, built from what each pass declares (as Falcor's reflect()).

A pass class declares at its top the resources it reads and writes:

    class AccumulatePass:
        name = "accumulate"
        inputs = ("frame", "history?")
        outputs = ("accumulation", "half difference", "moments")

A name is a resource that one pass makes and others read (a texture, a buffer). `name?` is an
optional port: an input the pass can do without, or an output it makes only in some settings;
the Node that puts the pass in a frame says which of them it uses. `previous name` reads what a
pass made in the previous frame (temporal reprojection): it needs that pass, but orders
nothing. A note in parentheses, `frame (with splats)`, is printed and not matched. A pass that
reads and writes one resource changes it in place (the upsample pass adds to the frame).

FrameGraph takes the passes that the settings could use and the resources asked for (each frame
makes the accumulation; a denoiser asks for `denoised`, the screen for `display`). It keeps the
passes those resources need, no others; orders them (a resource's maker first, then the passes
that change it in place, then its readers; otherwise in the order given); makes them in that
order; and prints --explain's pass list from the same declarations.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import LiftError

# What the renderer hands every pass rather than a pass making it.
EXTERNAL = ("scene", "camera", "jitter")
_PORT = re.compile(r"^(?P<previous>previous )?(?P<resource>[^?(]+?)(?P<optional>\?)?(?: \((?P<note>[^)]*)\))?$")


class GraphError(LiftError):
    """A frame whose passes' declarations do not fit together (a bug in lift-gl, not in a scene)."""


@dataclass(frozen=True)
class Port:
    resource: str
    optional: bool = False
    previous: bool = False   # the resource as the previous frame left it
    note: str = ""

    @classmethod
    def parse(cls, text: str) -> "Port":
        m = _PORT.match(text.strip())
        if m is None:
            raise GraphError(f"bad port {text!r}: NAME, NAME?, previous NAME, or NAME (note)")
        return cls(m["resource"].strip(), bool(m["optional"]), bool(m["previous"]), m["note"] or "")

    def text(self) -> str:
        return ("previous " if self.previous else "") + self.resource + (f" ({self.note})" if self.note else "")


@dataclass
class Node:
    """A pass that the settings may put in a frame.

    kind: the pass class, whose `inputs` and `outputs` declare its ports (a made pass's own
    attributes win: a pass may note what its settings add, e.g. `frame (with splats)`).
    make: makes the pass (allocating its textures and compiling its programs).
    uses: the optional ports (resource names) that these settings use.
    why: what --explain says the pass is there for; a callable gets the made pass.
    outputs: ports in place of the class's (a second pass of one kind that makes another
    resource: the viewer's noisy display beside the tone-mapped image)."""
    name: str
    kind: type
    make: Callable[[], Any]
    uses: tuple[str, ...] = ()
    why: str | Callable[[Any], str] = ""
    outputs: tuple[str, ...] | None = None

    def ports(self, declared=None) -> tuple[tuple[Port, ...], tuple[Port, ...]]:
        """(inputs, outputs) these settings use: required ports and the optional ones in `uses`.
        `declared`: the object whose declarations to read (the made pass; default the class)."""
        declared = self.kind if declared is None else declared
        inputs = [Port.parse(p) for p in declared.inputs]
        outputs = [Port.parse(p) for p in (self.outputs if self.outputs is not None else declared.outputs)]
        optional = {p.resource for p in inputs + outputs if p.optional}
        unknown = set(self.uses) - optional
        if unknown:
            raise GraphError(f"pass {self.name!r} ({self.kind.__name__}) has no optional port "
                             f"{', '.join(sorted(unknown))}")
        keep = [p for p in inputs if not p.optional or p.resource in self.uses]
        made = [p for p in outputs if not p.optional or p.resource in self.uses]
        return tuple(keep), tuple(made)


def plan(nodes: list[Node], asked, external=EXTERNAL) -> list[Node]:
    """The nodes that the resources `asked` need, in the order they run.

    A resource is needed when asked for or read by a needed pass (also as `previous`); its
    maker, and every pass that changes it in place, are then needed. Raises GraphError for a
    resource that no pass makes, one made by two passes, or a cycle."""
    ports = {n.name: n.ports() for n in nodes}
    makers, changers = {}, {}
    for n in nodes:
        inputs, outputs = ports[n.name]
        read = {p.resource for p in inputs if not p.previous}
        for p in outputs:
            if p.resource in read:
                changers.setdefault(p.resource, []).append(n)
            elif p.resource in makers:
                raise GraphError(f"{p.resource!r} is made by two passes: {makers[p.resource].name} and {n.name}")
            else:
                makers[p.resource] = n
    needed, wanted, stack = {}, set(), list(asked)
    while stack:
        resource = stack.pop()
        if resource in wanted or resource in external:
            continue
        wanted.add(resource)
        if resource not in makers:
            readers = [n.name for n in needed.values()
                       if any(p.resource == resource for p in ports[n.name][0])]
            raise GraphError(f"no pass makes {resource!r}" + (f" (read by {', '.join(readers)})" if readers else
                                                                " (asked for)"))
        for n in [makers[resource], *changers.get(resource, [])]:
            if n.name not in needed:
                needed[n.name] = n
                stack += [p.resource for p in ports[n.name][0]]
    return _ordered([n for n in nodes if n.name in needed], ports, makers, changers)


def _ordered(nodes: list[Node], ports: dict, makers: dict, changers: dict) -> list[Node]:
    """A resource's maker, then its changers in the order given, then its readers; else the order given."""
    names = {n.name for n in nodes}
    after = {n.name: set() for n in nodes}   # name -> the names that must run before it
    for resource, maker in makers.items():
        if maker.name not in names:
            continue
        chain = [maker.name] + [c.name for c in changers.get(resource, []) if c.name in names]
        for first, then in zip(chain, chain[1:]):
            after[then].add(first)
        for n in nodes:
            reads = any(p.resource == resource and not p.previous for p in ports[n.name][0])
            if reads and n.name not in chain:
                after[n.name].add(chain[-1])
    order, done = [], set()
    while len(order) < len(nodes):
        ready = next((n for n in nodes if n.name not in done and after[n.name] <= done), None)
        if ready is None:
            stuck = [n.name for n in nodes if n.name not in done]
            raise GraphError(f"the passes {', '.join(stuck)} wait on each other (a cycle)")
        order.append(ready)
        done.add(ready.name)
    return order


@dataclass
class FrameGraph:
    """The passes of a frame, made from the nodes that the asked resources need.

    nodes: every pass the settings could use, in the order they run when nothing else orders
    them. asked: the resources wanted (`frame_resources` of them each frame; the others on
    demand). on_make(name, made): called for each pass made (the renderer's timers)."""
    nodes: list[Node]
    asked: tuple[str, ...]
    frame_resources: tuple[str, ...] = ("accumulation",)
    external: tuple[str, ...] = EXTERNAL
    on_make: Callable[[str, Any], None] | None = None
    made: dict = field(default_factory=dict)   # name -> the pass, in run order

    def __post_init__(self):
        self.asked = tuple(dict.fromkeys(self.asked))
        self.made = self._make(plan(self.nodes, self.asked, self.external), {})

    def _make(self, order: list[Node], keep: dict) -> dict:
        """The passes of `order`, those in `keep` as they are and the others made now; if one
        cannot be made, the ones made here are released and the error raised."""
        made, new = {}, []
        try:
            for node in order:
                if node.name in keep:
                    made[node.name] = keep[node.name]
                else:
                    made[node.name] = node.make()
                    new.append(node.name)
        except BaseException:
            for name in new:
                made[name].release()
            raise
        for name in new:
            if self.on_make is not None:
                self.on_make(name, made[name])
        return made

    # ---- what the frame holds ----
    @property
    def passes(self) -> list:
        return list(self.made.values())

    def get(self, name: str):
        """The pass `name`, or None where this frame has none."""
        return self.made.get(name)

    def __contains__(self, name: str) -> bool:
        return name in self.made

    def node(self, name: str) -> Node:
        return next(n for n in self.nodes if n.name == name)

    def per_frame(self, name: str) -> bool:
        """Whether pass `name` runs every frame (the frame's resources need it), rather than on demand."""
        return name in {n.name for n in plan(self.nodes, self.frame_resources, self.external)} and name in self.made

    # ---- changes ----
    def ask(self, resource: str) -> None:
        """Want `resource` too (an AOV, the screen): the passes it needs are made now."""
        if resource in self.asked:
            return
        order = plan(self.nodes, self.asked + (resource,), self.external)
        self.made = self._make(order, self.made)
        self.asked += (resource,)

    def rebuild(self, nodes: list[Node] | None = None, asked=None, remake=()) -> None:
        """Take new nodes (settings changed) or asked resources: passes still needed stay as
        they are, but those named in `remake`, which are made anew; those no longer needed
        are released. All or nothing: if a pass cannot be made, the graph stays as it was.
        remake=True: every pass made anew, the old ones released first (a new size: the two
        sets of textures are not held at once)."""
        nodes = self.nodes if nodes is None else nodes
        asked = self.asked if asked is None else tuple(dict.fromkeys(asked))
        order = plan(nodes, asked, self.external)
        if remake is True:
            self.release()
        keep = {k: v for k, v in self.made.items() if k not in set(remake or ())} if remake is not True else {}
        made = self._make(order, keep)
        for name, old in self.made.items():
            if made.get(name) is not old:
                old.release()
        self.nodes, self.asked, self.made = nodes, asked, made

    def swap(self, name: str, made) -> Any:
        """Put `made` in the place of pass `name` (a recompiled trace program); the old one is
        returned, not released."""
        old = self.made[name]
        self.made[name] = made
        return old

    def release(self) -> None:
        for made in self.made.values():
            made.release()
        self.made = {}

    # ---- --explain ----
    def explain(self, skip=()) -> list[str]:
        """One line a pass, in run order: `name  inputs -> outputs: why` from the declarations."""
        lines = []
        for name, made in self.made.items():
            if name in skip:
                continue
            node = self.node(name)
            inputs, outputs = node.ports(made)
            why = node.why(made) if callable(node.why) else node.why
            when = "" if self.per_frame(name) else " [on demand]"
            lines.append(f"  {name:<11} {', '.join(p.text() for p in inputs)} -> "
                         f"{', '.join(p.text() for p in outputs)}{when}" + (f": {why}" if why else ""))
        return lines
