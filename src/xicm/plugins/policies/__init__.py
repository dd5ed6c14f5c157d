"""Built-in policies: X-ICM (the method) and the scripted oracle (the upper bound)."""
