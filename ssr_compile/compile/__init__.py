"""Compiler passes: PDDLStream -> plain cost-PDDL, one module per pass."""
