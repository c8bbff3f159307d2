"""Where the parts of a netlist go in its drawing: nodes on tracks, parts across them in slots.

Both drawings of a netlist — a circuit's schematic (:mod:`models.schematic`) and a mechanism's
lumped diagram (:mod:`models.lumped_diagram`) — are placed here, the same way:

* every node is a straight *bus* along a *track*: a circuit's node a horizontal wire on a row, a
  mechanism's node a vertical bar (its mass's block) in a column.  Several nodes may share a track
  when their buses do not overlap; the reference node (ground, the frame) has a track of its own at
  one side (the bottom rail of a circuit, the wall on the left of a mechanism);
* every part is a :class:`Piece` drawn straight across the tracks, in a *slot* (a column of a
  circuit, a lane of a mechanism), from its first node's track to its second's, its symbol in one
  gap between two neighbouring tracks; a piece on one node (a force) reaches half a gap to one side;
* in a circuit, parts in series between nodes that nothing else ties are drawn *along* a track, a
  chain of nodes on one row (the switch and the inductor of a buck converter, between its input,
  switch node and output), each in a slot of its own between its two nodes' buses.

So the drawing is right by construction: a bus touches the parts of its node and no other (buses of
one track never overlap, a slot's parts never overlap), and a part that passes a bus of another
node crosses it (no dot, no connection).  Of the orders of the slots, the one taken has the fewest
crossings, then the shortest buses: a local search from a topological order of the chains; then
neighbouring slots whose parts do not overlap are merged (a spring, a mass and a second spring on
one line).  Tracks: from the first node (a circuit's source: its chain on the top row) or from the
reference (a mechanism's frame: the wall, then its nodes outwards), each node on the nearest track
its drawn neighbours leave free.  Where chains cannot all be kept (a loop of series parts, two
chains that would interleave), a part leaves its chain and is drawn across; where nodes cannot share
a track, each takes its own: the last resort, one node per track, always draws.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

__all__ = ["Piece", "Layout", "Geometry", "place", "geometry"]

#: units of the local search beyond which a unit is tried only this many slots away
NEAR = 10
#: passes of the local search
PASSES = 4


@dataclass(frozen=True)
class Piece:
    """One straight part of a drawing: ``name`` (a component's, or ``"K1:p"`` for a winding of
    one), ``nodes`` (two, or one for a part on one node), ``side`` (a one-node piece reaches half a
    gap towards higher tracks, ``+1``, lower ones, ``-1``, or nowhere, ``0``), ``group`` (pieces of
    one group stay in neighbouring slots, in order: a transformer's windings) and ``series`` (it may
    be drawn along a track: a two-terminal part between two nodes other than the reference)."""

    name: str
    nodes: tuple
    side: int = 1
    group: str = ""
    series: bool = False


@dataclass
class Layout:
    """The places of a netlist's pieces: ``tracks`` (node → track), ``slots`` (a list of slots,
    each the names of the pieces in it), ``along`` (the pieces drawn along a track: name →
    ``(left node, right node)``), ``pieces`` (name → :class:`Piece`), ``reference`` (its node)."""

    tracks: dict
    slots: list
    along: dict
    pieces: dict
    reference: str

    def interval(self, name: str) -> tuple:
        """The tracks a piece spans, ``(low, high)`` (a one-node piece: half a gap to its side)."""
        return _interval(self.pieces[name], self.tracks, self.along)


@dataclass
class Geometry:
    """A layout in coordinates ``(u, v)``: ``u`` along the slots, ``v`` along the tracks.

    ``ends``: piece → its terminal points, in its nodes' order; ``body``: piece → ``(start, end)``
    of its symbol (``start`` towards its first node); ``leads``: ``(node, p, q)`` wires between a
    terminal and a symbol; ``buses``: node → ``(p, q)``, its wire along its track (``p == q`` when
    one point); ``dots``: the points where three or more wires meet."""

    ends: dict
    body: dict
    leads: list
    buses: dict
    dots: list


def place(pieces, reference: str, *, start=None, chains: bool = True, reference_first: bool = False) -> Layout:
    """The :class:`Layout` of ``pieces`` (in the netlist's order) around the ``reference`` node.

    ``chains``: draw series parts along tracks (a circuit); ``start``: the node whose chain is drawn
    first (a circuit's source); ``reference_first``: the reference's track comes first and the
    nodes are placed outwards from it (a mechanism's frame), else it comes last (a circuit's ground,
    below every row)."""
    pieces = list(pieces)
    by_name = {p.name: p for p in pieces}
    demoted: set = set()
    while True:
        along = _chains(pieces, reference, start, demoted) if chains else {}
        units = _units(pieces)
        ranked = _topological(units, pieces, along)
        if ranked is not None:
            break
        demoted.add(_last_in_cycle(units, pieces, along))
    for shared in (True, False):
        tracks = _tracks(pieces, reference, along, start, reference_first, shared)
        order = _search(ranked, lambda slots: _score(slots, by_name, tracks, along))
        slots = [[name] for unit in order for name in unit]
        score = _score(slots, by_name, tracks, along)
        if score[0] == 0:
            break
    slots = _merged(slots, by_name, tracks, along)
    return Layout(tracks, slots, along, by_name, reference)


# -- chains and tracks

def _chains(pieces, reference: str, start, demoted: set) -> dict:
    """Series pieces drawn along tracks: name → ``(left, right)``.  Each chain grows from a seed
    node (``start`` first, then the nodes in order of appearance), to the right and then to the
    left, by the first series piece at its end whose other node is in no chain and tied to the
    chain by no other piece."""
    chain_of: dict = {}
    along: dict = {}
    seeds = [start] if start is not None else []
    seeds += [n for p in pieces for n in p.nodes]
    for seed in seeds:
        if seed == reference or seed in chain_of:
            continue
        chain = [seed]
        chain_of[seed] = chain
        for rightwards in (True, False):
            while True:
                end = chain[-1] if rightwards else chain[0]
                step = _next_link(pieces, reference, end, chain, chain_of, along, demoted)
                if step is None:
                    break
                piece, other = step
                chain_of[other] = chain
                if rightwards:
                    chain.append(other)
                    along[piece.name] = (end, other)
                else:
                    chain.insert(0, other)
                    along[piece.name] = (other, end)
    return along


def _next_link(pieces, reference, end, chain, chain_of, along, demoted):
    members = set(chain)
    for piece in pieces:
        if (not piece.series or piece.name in demoted or piece.name in along or end not in piece.nodes
                or reference in piece.nodes):
            continue
        other = piece.nodes[1] if piece.nodes[0] == end else piece.nodes[0]
        if other in chain_of:
            continue
        tied = any(q is not piece and other in q.nodes and members.intersection(q.nodes) for q in pieces)
        if not tied:
            return piece, other
    return None


def _units(pieces) -> list:
    """The pieces as units of the order: a group's pieces together, in order; every other piece alone."""
    units, seen = [], {}
    for p in pieces:
        if p.group:
            if p.group in seen:
                seen[p.group].append(p.name)
                continue
            seen[p.group] = [p.name]
            units.append(seen[p.group])
        else:
            units.append([p.name])
    return [tuple(u) for u in units]


def _precedences(units, pieces, along) -> dict:
    """unit → the units that must come after it: a chain's pieces keep its order (every piece of
    its left node before the piece along, every piece of its right node after)."""
    unit_of = {name: u for u in units for name in u}
    after = {u: set() for u in units}
    for name, (left, right) in along.items():
        for p in pieces:
            if p.name == name:
                continue
            if left in p.nodes and unit_of[p.name] != unit_of[name]:
                after[unit_of[p.name]].add(unit_of[name])
            if right in p.nodes and unit_of[p.name] != unit_of[name]:
                after[unit_of[name]].add(unit_of[p.name])
    return after


def _topological(units, pieces, along):
    """The units in an order that keeps every chain's (the netlist's order where free), or ``None``
    when the chains' orders contradict each other."""
    after = _precedences(units, pieces, along)
    before = {u: 0 for u in units}
    for u in units:
        for v in after[u]:
            before[v] += 1
    rank = {u: k for k, u in enumerate(units)}
    ready = sorted((u for u in units if before[u] == 0), key=rank.get)
    order = []
    while ready:
        u = ready.pop(0)
        order.append(u)
        for v in after[u]:
            before[v] -= 1
            if before[v] == 0:
                ready.append(v)
        ready.sort(key=rank.get)
    return order if len(order) == len(units) else None


def _last_in_cycle(units, pieces, along) -> str:
    """A piece along a track on a cycle of the chains' orders (the last such in the netlist): it
    leaves its chain."""
    after = _precedences(units, pieces, along)
    before = {u: 0 for u in units}
    for u in units:
        for v in after[u]:
            before[v] += 1
    ready = [u for u in units if before[u] == 0]
    while ready:  # strip what is not on a cycle
        u = ready.pop()
        for v in after[u]:
            before[v] -= 1
            if before[v] == 0:
                ready.append(v)
    stuck = {name for u in units if before[u] > 0 for name in u}
    return [p.name for p in pieces if p.name in along and p.name in stuck][-1]


def _tracks(pieces, reference, along, start, reference_first: bool, shared: bool) -> dict:
    """node → track.  A chain's nodes share one; chains are visited breadth first from ``start``'s
    (or from the reference), each on the first track at or beyond its depth that no neighbour drawn
    before took (``shared``) or that no chain took at all; the reference first or last."""
    chain_of = {}
    for left, right in along.values():
        a, b = chain_of.setdefault(left, {left}), chain_of.setdefault(right, {right})
        if a is not b:
            a |= b
            for n in b:
                chain_of[n] = a
    nodes = list(dict.fromkeys(n for p in pieces for n in p.nodes))
    key = {n: min(chain_of.get(n, {n}), key=nodes.index) for n in nodes}  # a chain by its first node
    neighbours = {key[n]: set() for n in nodes}
    for p in pieces:
        if p.name not in along and len(p.nodes) == 2:
            a, b = key[p.nodes[0]], key[p.nodes[1]]
            neighbours[a].add(b)
            neighbours[b].add(a)
    depth: dict = {}
    track: dict = {}
    roots = [key[reference]] if reference_first and reference in key else []
    roots += [key[start]] if start in key else []
    roots += [key[n] for n in nodes]
    for root in roots:
        if root in track or (root == key.get(reference) and not reference_first):
            continue
        depth[root] = 1 if reference_first and root != key.get(reference) else 0
        queue = deque([root])
        while queue:
            c = queue.popleft()
            taken = {track[d] for d in (neighbours[c] if shared else track) if d in track}
            t = depth[c]
            while t in taken:
                t += 1
            track[c] = t
            for d in sorted(neighbours[c], key=nodes.index):
                if d not in depth and not (d == key.get(reference) and not reference_first):
                    depth[d] = depth[c] + 1
                    queue.append(d)
    if not reference_first and reference in key:
        track[key[reference]] = max(track.values(), default=-1) + 1
    return {n: track[key[n]] for n in nodes}


# -- the order of the slots

def _interval(piece, tracks, along) -> tuple:
    if piece.name in along:
        t = tracks[piece.nodes[0]]
        return (t, t)
    if len(piece.nodes) == 1:
        t = tracks[piece.nodes[0]]
        return tuple(sorted((t, t + 0.5 * piece.side)))
    a, b = tracks[piece.nodes[0]], tracks[piece.nodes[1]]
    return (min(a, b), max(a, b))


def _attachments(slots, pieces, along):
    """``(node, position)`` of every terminal, positions in half slots: ``2k`` across slot ``k``,
    ``2k ∓ 1`` for the left and right nodes of a piece along a track in it."""
    for k, slot in enumerate(slots):
        for name in slot:
            if name in along:
                left, right = along[name]
                yield left, 2 * k - 1
                yield right, 2 * k + 1
            else:
                for n in pieces[name].nodes:
                    yield n, 2 * k


def _spans(slots, pieces, along) -> dict:
    spans: dict = {}
    for n, x in _attachments(slots, pieces, along):
        lo, hi = spans.get(n, (x, x))
        spans[n] = (min(lo, x), max(hi, x))
    return spans


def _score(slots, pieces, tracks, along) -> tuple:
    """``(conflicts, crossings, length)`` of an order of slots: conflicts are the pairs of buses of one
    track that overlap and the pairs of pieces of one slot that do (both 0 in a drawing that is
    right), crossings the pieces passing a bus of another node, length the buses' total length."""
    spans = _spans(slots, pieces, along)
    by_track: dict = {}
    for n, span in spans.items():
        by_track.setdefault(tracks[n], []).append(span)
    conflicts = 0
    for group in by_track.values():
        group.sort()
        for (lo1, hi1), (lo2, hi2) in zip(group, group[1:]):
            if lo2 <= hi1:
                conflicts += 1
    crossings = 0
    for k, slot in enumerate(slots):
        if len(slot) > 1:
            conflicts += _slot_conflicts(slot, pieces, tracks, along)
        for name in slot:
            lo, hi = _interval(pieces[name], tracks, along)
            if hi - lo < 2:
                continue
            for n, (a, b) in spans.items():
                if lo < tracks[n] < hi and a <= 2 * k <= b:
                    if a == 2 * k or b == 2 * k:
                        conflicts += 1  # a bus ending on a piece that passes it: a false junction
                    else:
                        crossings += 1
    length = sum(hi - lo for lo, hi in spans.values())
    return conflicts, crossings, length


def _slot_conflicts(slot, pieces, tracks, along) -> int:
    """Pairs of pieces in one slot that overlap, or touch at a track where their nodes differ."""
    found = 0
    items = [(pieces[name], _interval(pieces[name], tracks, along)) for name in slot]
    for i, (p, (lo1, hi1)) in enumerate(items):
        for q, (lo2, hi2) in items[i + 1:]:
            if p.name in along or q.name in along or max(lo1, lo2) < min(hi1, hi2):
                found += 1
            elif max(lo1, lo2) == min(hi1, hi2):
                t = max(lo1, lo2)
                at_p = {n for n in p.nodes if tracks[n] == t}
                at_q = {n for n in q.nodes if tracks[n] == t}
                if not at_p or at_p != at_q:
                    found += 1
    return found


def _search(order, score) -> list:
    """A local search over the order of the units: each moved to the place that lowers the score
    most (a few passes; far from its place only in small drawings)."""
    order = list(order)

    def slots_of(units):
        return [[name] for unit in units for name in unit]

    best = score(slots_of(order))
    near = len(order) if len(order) <= 3 * NEAR else NEAR
    for _ in range(PASSES):
        improved = False
        for unit in list(order):
            i = order.index(unit)
            rest = order[:i] + order[i + 1:]
            choice = None
            for j in range(max(0, i - near), min(len(rest), i + near) + 1):
                if j == i:
                    continue
                trial = rest[:j] + [unit] + rest[j:]
                s = score(slots_of(trial))
                if s < best:
                    best, choice = s, trial
            if choice is not None:
                order, improved = choice, True
        if not improved or (best[:2] == (0, 0) and len(order) > 3 * NEAR):
            break
    return order


def _merged(slots, pieces, tracks, along) -> list:
    """Slots merged where their pieces do not overlap: each slot takes the pieces of a later one (a
    few slots on) when the score stays as low (a spring, a mass and the next spring on one line; a
    bridge leg's switches one above the other)."""
    slots = [list(s) for s in slots]
    best = _score(slots, pieces, tracks, along)
    k = 0
    while k < len(slots):
        j = k + 1
        while j < min(len(slots), k + 1 + NEAR):
            if any(name in along or pieces[name].group for name in slots[k] + slots[j]):
                j += 1
                continue
            trial = [slot + slots[j] if i == k else slot for i, slot in enumerate(slots) if i != j]
            s = _score(trial, pieces, tracks, along)
            if s <= best:
                slots, best = trial, s
            else:
                j += 1
        k += 1
    return slots


# -- coordinates

def geometry(layout: Layout, track_at, slot_at, *, margin=0.25, stub: float = 1.0, body_gap=None) -> Geometry:
    """The :class:`Geometry` of ``layout``: ``track_at(t)`` the ``v`` of track ``t``; ``slot_at(k)``
    ``(u, start, end)``: the ``u`` of slot ``k``'s pieces across the tracks, and where a piece along a
    track starts and ends.  A symbol leaves ``margin`` of its gap at each end (so a line crossing a bus is
    never a symbol's end; a function of the track: what the track's node takes, a mass's block); a one-node
    piece reaches ``stub`` beyond it.  ``body_gap(piece, low, high)`` picks the
    gap of a symbol (``(t, t + 1)``) between the tracks a piece spans (default: the first)."""
    ends, body, leads = {}, {}, []
    room = margin if callable(margin) else (lambda t: margin)
    outwards = 1 if track_at(1) > track_at(0) else -1  # the direction of higher tracks
    for k, slot in enumerate(layout.slots):
        u, start, end = slot_at(k)
        for name in slot:
            piece = layout.pieces[name]
            if name in layout.along:
                left, right = layout.along[name]
                v = track_at(layout.tracks[left])
                points = {left: (start, v), right: (end, v)}
                ends[name] = tuple(points[n] for n in piece.nodes)
                a, b = ends[name]
                sign = 1 if b[0] > a[0] else -1
                body[name] = ((a[0] + sign * room(None), v), (b[0] - sign * room(None), v))
            elif len(piece.nodes) == 1:
                v = track_at(layout.tracks[piece.nodes[0]])
                ends[name] = ((u, v),)
                near = v + outwards * piece.side * room(layout.tracks[piece.nodes[0]])
                body[name] = ((u, near), (u, near + outwards * piece.side * stub))
            else:
                a, b = (layout.tracks[n] for n in piece.nodes)
                lo, hi = min(a, b), max(a, b)
                gap = body_gap(piece, lo, hi) if body_gap else lo
                near_a = gap if a < b else gap + 1
                va, vb = track_at(a), track_at(b)
                near_b = gap + 1 if near_a == gap else gap
                ga, gb = track_at(near_a), track_at(near_b)
                sign = 1 if gb > ga else -1
                ends[name] = ((u, va), (u, vb))
                body[name] = ((u, ga + sign * room(near_a)), (u, gb - sign * room(near_b)))
            for n, terminal, inner in zip(piece.nodes, ends[name], body[name]):
                if terminal != inner:
                    leads.append((n, terminal, inner))
    buses = _buses(ends, layout.pieces)
    return Geometry(ends, body, leads, buses, _dots(ends, body, layout.pieces, buses))


def _buses(ends, pieces) -> dict:
    points: dict = {}
    for name, terminals in ends.items():
        for n, p in zip(pieces[name].nodes, terminals):
            points.setdefault(n, []).append(p)
    buses = {}
    for n, ps in points.items():
        buses[n] = (min(ps), max(ps))
    return buses


def _dots(ends, body, pieces, buses) -> list:
    """Terminal points where three or more wires meet (the bus on either side, the pieces' leads)."""
    ways: dict = {}
    for name, terminals in ends.items():
        (a, b) = body[name]
        middle = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
        for n, p in zip(pieces[name].nodes, terminals):
            du, dv = middle[0] - p[0], middle[1] - p[1]
            way = ("u", du > 0) if abs(du) > abs(dv) else ("v", dv > 0) if dv else None
            ways.setdefault((n, p), set()).add(way)
    dots = []
    for (n, p), found in ways.items():
        lo, hi = buses[n]
        found.discard(None)
        if lo < p:
            found.add(("u", False))
        if p < hi:
            found.add(("u", True))
        if len(found) >= 3:
            dots.append(p)
    return sorted(set(dots))
