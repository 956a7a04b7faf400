"""Python stream implementations for the shipped domains."""
