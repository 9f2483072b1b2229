"""User commands: the `hapgate` CLI and what its subcommands run (demo, bench, replay).
May import every other layer; nothing imports it."""
