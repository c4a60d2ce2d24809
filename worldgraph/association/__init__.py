"""The consistency graph, cliques, filters, hypotheses: data association of percepts to objects.

* :mod:`worldgraph.association.matching`: :func:`associate`, which drives both methods (the
  typed consistency-graph cliques and the paper's filters); its public names are re-exported
  here, so ``worldgraph.association`` keeps the names it had as a module.
* :mod:`worldgraph.association.consistency`: the typed consistency graph (candidate pairs, far
  pairs, pruning).
* :mod:`worldgraph.association.cliques`: the maximum-clique search.
* :mod:`worldgraph.association.filters`: the paper's filters (eqs. 1-3) and the discriminator.
* :mod:`worldgraph.association.hypotheses`: hypothesis fits, the mirror check, ranking.
"""

from .matching import (
    ASSOCIATION_METHODS,
    ASSOCIATION_TOLERANCES,
    AssociationHypothesis,
    AssociationTolerances,
    CliqueSearch,
    associate,
    consistency_graph,
    discriminator,
    filtered_graph_view,
    is_ambiguous,
    maximum_cliques,
    orientation_filter,
    proximity_filter,
    same_pose,
)

__all__ = [
    "ASSOCIATION_METHODS",
    "ASSOCIATION_TOLERANCES",
    "AssociationHypothesis",
    "AssociationTolerances",
    "CliqueSearch",
    "associate",
    "consistency_graph",
    "filtered_graph_view",
    "discriminator",
    "is_ambiguous",
    "maximum_cliques",
    "same_pose",
    "orientation_filter",
    "proximity_filter",
]
