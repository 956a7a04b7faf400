"""Shipped example domains (package data, installed as ssr_compile.domains)."""
