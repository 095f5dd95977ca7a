"""Property groups, operators and panels."""
