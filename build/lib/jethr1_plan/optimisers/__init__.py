"""optimisers."""
