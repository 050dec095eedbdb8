"""Written folders read back whole, with the scenario they were planned from."""
