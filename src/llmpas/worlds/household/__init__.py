"""llmpas.worlds.household: a household with a hidden true state."""
