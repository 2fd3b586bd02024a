"""What a run writes: its directory (lock, atomic writes), tables and figures, and the
report that renders them again (``docs/commands.md``, "report")."""
