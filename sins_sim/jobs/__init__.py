"""Jobs: validated configuration -> engine -> result files."""
