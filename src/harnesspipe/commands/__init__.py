"""Sub-commands of the ``harnesspipe`` console command (see harnesspipe.cli)."""
