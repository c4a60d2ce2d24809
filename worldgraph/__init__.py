"""worldgraph: world model graph, association and pose."""
