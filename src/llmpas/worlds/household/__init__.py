"""llmpas.worlds.household: a household with a hidden true state."""

from llmpas.worlds.api import WorldEntry

WORLD_ENTRY = WorldEntry(
    "household",
    "llmpas.worlds.household.household_plugin:WORLD",
    oracle="llmpas.worlds.household.household_oracle:oracle",
    rank=0,
    help="a household scenario name, or a household .toml",
    files="llmpas.worlds.household.household_plugin:scenario_path",
    tasks="llmpas.worlds.household.household_tasks:judged",
)
