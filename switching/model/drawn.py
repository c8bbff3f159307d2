"""A model shown in a notebook: its bond graph, drawn as ``hbg draw`` draws it, as inline SVG.

:class:`ShownAsBondGraph` gives :class:`~switching.model.hybrid_model.HybridModel` its ``_repr_svg_``
(a notebook cell that ends with a model shows its graph) and :meth:`~ShownAsBondGraph.bond_graph_svg`:
the graph in a mode (default: the initial one), every controlled junction marked with its automaton's
state in the words the run says (``closed``, ``blocking``), as :func:`bondgraph.drawing.draw_bond_graph`
draws it; texts stay SVG text.  A model built from a circuit or a mechanism draws its netlist too:
``model.built_from.netlist.draw(mode)`` (:mod:`models.schematic`, :mod:`models.lumped_diagram`).
"""

from __future__ import annotations

import io

__all__ = ["ShownAsBondGraph"]


class ShownAsBondGraph:
    """What a model adds to be shown in a notebook (see the module documentation)."""

    def bond_graph_svg(self, mode=None) -> str:
        """The bond graph in ``mode`` (a mode or its text; default: the initial mode) as SVG text."""
        import matplotlib

        from bondgraph.drawing import draw_bond_graph, pyplot

        mode = self.initial_mode if mode is None else self.mode(mode)
        with matplotlib.rc_context({"svg.fonttype": "none"}):  # the names stay text
            ax = draw_bond_graph(self.graph, self.configuration_of(mode), title=f"{self.name} in mode "
                                 f"{mode.describe()}", words=self.mode_space.junction_words(mode))
            try:
                out = io.StringIO()
                ax.figure.savefig(out, format="svg")
            finally:
                pyplot().close(ax.figure)
        return out.getvalue()

    def _repr_svg_(self):
        from bondgraph.errors import HybridBondGraphError

        try:
            return self.bond_graph_svg()
        except HybridBondGraphError:  # a graph its initial mode cannot draw: the notebook shows the text
            return None
