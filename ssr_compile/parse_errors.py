"""Parse errors in words: a Lark exception -> a PDDLSyntaxError naming file:line:col.

The message says what was found and what the parser could accept there, in the file's own
terms (keywords as written, ``')' too early``, ``3 unclosed '('``), as Lark's
``examples/advanced/error_reporting_lalr.py`` suggests.
"""

from __future__ import annotations

import re

from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from .errors import PDDLSyntaxError

# What each terminal is, in words.
_WORDS = {
    "LPAR": "'('",
    "RPAR": "')'",
    "NAME": "a name",
    "VARIABLE": "a variable such as ?x",
    "NUMBER": "a number",
    "MINUS": "'-'",
    "COMP": "a comparison (=, <, <=, >, >=)",
    "ARITH_OP": "an arithmetic operator (+, *, /)",
    "ASSIGN_OP": "a numeric effect (increase, decrease, assign, scale-up, scale-down)",
    "REQ_FLAG": "a requirement such as :strips",
    "TIME_SPEC": "'at start', 'at end' or 'over all'",
    "OPTIMIZATION": "'minimize' or 'maximize'",
    "$END": "the end of the file",
}
_KEYWORDS = {
    "DEFINE": "define",
    "DOMAIN": "domain",
    "PROBLEM": "problem",
    "STREAM": "stream",
    "AND": "and",
    "OR": "or",
    "NOT": "not",
    "IMPLY": "imply",
    "EXISTS": "exists",
    "FORALL": "forall",
    "WHEN": "when",
    "EITHER": "either",
}
# After these keywords, what must come next, in words.
_AFTER = {
    ":parameters": "a parameter list such as (?x ?y - type)",
    ":param": "a parameter list such as (?x ?y - type)",
    ":precondition": "a condition such as (and (p ?x) (not (q ?x)))",
    ":pre": "a condition such as (and (p ?x) (not (q ?x)))",
    ":effect": "an effect such as (and (p ?x) (not (q ?x)))",
    ":eff": "an effect such as (and (p ?x) (not (q ?x)))",
    ":inputs": "a variable list such as (?x ?y)",
    ":inp": "a variable list such as (?x ?y)",
    ":outputs": "a variable list such as (?y)",
    ":out": "a variable list such as (?y)",
    ":domain": "a condition such as (and (p ?x))",
    ":dom": "a condition such as (and (p ?x))",
    ":certified": "a condition such as (and (p ?x ?y))",
    ":cert": "a condition such as (and (p ?x ?y))",
    ":fluents": "a list of predicate names such as (atpose)",
    ":goal": "a goal condition such as (and (p a))",
    ":predicates": "predicate declarations such as (p ?x - type)",
    ":types": "type names",
    ":constants": "object names",
    ":objects": "object names",
    ":init": "initial facts such as (p a)",
    ":requirements": "requirement flags such as :strips",
    ":derived": "the derived predicate's head such as (p ?x)",
    ":action": "the action's name",
    ":stream": "the stream's name",
    "define": "'(' and the file's kind: (domain NAME), (problem NAME) or (stream NAME)",
    "either": "type names",
}


def _describe_expected(expected: set[str], prev: str | None) -> str:
    expected = {e for e in expected if e != "STRAY"}
    prev_l = (prev or "").lower()
    if prev_l in _AFTER and not (prev_l == ":domain" and expected <= {"NAME"}):
        return f"{_AFTER[prev_l]} after {prev}"
    words = []
    keywords = []
    for e in sorted(expected):
        if e in _WORDS:
            words.append(_WORDS[e])
        elif e in _KEYWORDS:
            keywords.append(_KEYWORDS[e])
        elif e.endswith("_KEY") or e.isupper():
            keywords.append(_keyword_text(e))
    if keywords:
        kw = ", ".join(keywords[:12]) + (", ..." if len(keywords) > 12 else "")
        words.insert(0, f"one of {kw}" if len(keywords) > 1 else keywords[0])
    if not words:
        return "something else"
    if len(words) == 1:
        text = words[0]
    else:
        text = ", ".join(words[:-1]) + " or " + words[-1]
    if prev:
        text += f" after {prev!r}" if prev in "()" else f" after {prev}"
    return text


def _keyword_text(terminal: str) -> str:
    """The spelling of a keyword terminal such as PRECONDITION -> :precondition."""
    base = terminal.removesuffix("_KEY").lower().replace("_", "-")
    return ":" + base


TOKEN = re.compile(r";[^\n]*|[()]|[^\s();]+")


def _previous_token(text: str, pos: int) -> str | None:
    last = None
    for m in TOKEN.finditer(text, 0, pos):
        if not m.group().startswith(";"):
            last = m.group()
    return last


def _found(text: str, pos: int) -> str:
    if pos >= len(text):
        return "the end of the file"
    m = re.compile(r"[^\s()]+|.").match(text, pos)
    word = m.group() if m else text[pos]
    if len(word) > 40:
        word = word[:40] + "..."
    if not word.isprintable():
        return f"the character {word[0]!r}" if len(word) == 1 else f"{word!r}"
    return f"'{word}'"


def _end_position(text: str) -> tuple[int, int]:
    stripped = text.rstrip()
    line = stripped.count("\n") + 1
    col = len(stripped) - (stripped.rfind("\n") + 1) + 1
    return line, col


def syntax_error(e: UnexpectedInput, text: str, filename: str) -> PDDLSyntaxError:
    expected = _acceptable(e)
    if isinstance(e, UnexpectedToken) and e.token.type == "$END":
        if _previous_token(text, len(text)) is None:
            line, col = 1, 1
            return PDDLSyntaxError(
                "the file is empty (nothing but blanks and comments); expected "
                "(define (domain NAME) ...), (define (problem NAME) ...) or (define (stream NAME) ...)",
                file=filename,
                line=line,
                col=col,
                source=text,
            )
        line, col = _end_position(text)
        depth = _open_parens(text)
        hint = f" ({depth} unclosed '(')" if depth > 0 else ""
        message = f"found the end of the file{hint}; expected {_describe_expected(expected, None)}"
        return PDDLSyntaxError(message, file=filename, line=line, col=col, source=text)
    if isinstance(e, UnexpectedToken):
        pos = e.token.start_pos
    elif isinstance(e, UnexpectedCharacters):
        pos = e.pos_in_stream
    else:  # pragma: no cover - other Lark errors do not occur with LALR
        pos = getattr(e, "pos_in_stream", 0) or 0
    line, col = e.line, e.column
    if line is None or line < 1:
        line = text.count("\n", 0, pos) + 1
        col = pos - (text.rfind("\n", 0, pos) + 1) + 1
    prev = _previous_token(text, pos)
    found = _found(text, pos)
    if found.strip("'") == ")" and expected == {"$END"}:
        return PDDLSyntaxError(
            "found one ')' too many after the end of the file's (define ...)",
            file=filename,
            line=line,
            col=col,
            source=text,
        )
    if found.strip("'") == ")" and expected and "RPAR" not in expected:
        found = "')' too early"
    message = f"found {found}; expected {_describe_expected(expected, prev)}"
    return PDDLSyntaxError(message, file=filename, line=line, col=col, source=text)


def _acceptable(e: UnexpectedInput) -> set[str]:
    """The terminals the parser could really accept where it failed.

    LALR merges states, so the ``expected`` set of an error may list terminals that only other
    contexts accept; asking the interactive parser (which tries each one) gives the exact set.
    """
    fallback = set(getattr(e, "expected", None) or getattr(e, "allowed", None) or ())
    ip = getattr(e, "interactive_parser", None)
    if ip is None:
        return fallback
    try:
        return set(ip.accepts()) or fallback
    except Exception:  # a reduction on a copy of the parser refused its input
        return fallback


def _open_parens(text: str) -> int:
    depth = 0
    for m in TOKEN.finditer(text):
        tok = m.group()
        if tok == "(":
            depth += 1
        elif tok == ")":
            depth -= 1
    return depth
