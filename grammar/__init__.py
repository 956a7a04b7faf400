"""Lark grammars for the PDDLStream dialect (package data, installed as ssr_compile.grammar)."""
