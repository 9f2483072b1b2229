"""Tool flows: the block registry, lint and synthesis (Yosys), place and route for boards.
Imports `hapgate.base` and `hapgate.golden`."""
