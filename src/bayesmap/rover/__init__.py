"""rover."""
