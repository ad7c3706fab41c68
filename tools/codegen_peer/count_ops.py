#!/usr/bin/python3
"""One operation counter for emitted C/C++ kernels, applied alike to pardel's and SymPy's code.

It finds a function's body by name, parses every assignment's right-hand side into an
expression tree and counts:
  - each binary + - * / = 1 op (a compound assignment += -= *= /= also counts 1),
  - each unary minus = 1 op (unary plus = 0),
  - each function call = 1 op (sin, std::sin, pow, sqrt, ... alike, whatever its arguments),
  - no op for an operation whose operands are all literal constants (e.g. 1.0/2.0, -0.5,
    sqrt(3)): the compiler folds it;
  - no op for copies (a = b), array indexing, (void) casts and declarations.

Divisions are also reported apart: they cost several multiplications on current CPUs.

Usage:
  /usr/bin/python3 count_ops.py FILE FUNCTION   -> prints the count and the divisions among them
"""

import re
import sys

_TOKEN = re.compile(r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[fFlL]?)"
                    r"|(?P<id>[A-Za-z_][A-Za-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)*)"
                    r"|(?P<op>[-+*/(),\[\]]))")


class CountError(Exception):
    pass


def function_body(text, name):
    """The text between the braces of the definition of `name`."""
    m = re.search(r"\b%s\s*\([^)]*\)\s*\{" % re.escape(name), text)
    if not m:
        raise CountError("function '%s' not found" % name)
    depth, start = 1, m.end()
    for i in range(start, len(text)):
        if text[i] == "{":
            depth += 1
        elif text[i] == "}":
            depth -= 1
            if depth == 0:
                return text[start:i]
    raise CountError("unbalanced braces in '%s'" % name)


def _tokens(expr):
    out, pos = [], 0
    expr = expr.strip()
    while pos < len(expr):
        m = _TOKEN.match(expr, pos)
        if not m or m.end() == pos:
            raise CountError("cannot read '%s' at '%s'" % (expr, expr[pos:pos + 20]))
        kind = m.lastgroup
        out.append((kind, m.group(kind)))
        pos = m.end()
    return out


class _Parser:
    """Recursive descent over C arithmetic; each method returns (ops, is_constant)."""

    def __init__(self, tokens):
        self.t = tokens
        self.i = 0
        self.divisions = 0  # counted (not folded) divisions

    def peek(self):
        return self.t[self.i] if self.i < len(self.t) else (None, None)

    def take(self, value=None):
        tok = self.peek()
        if tok[0] is None or (value is not None and tok[1] != value):
            raise CountError("expected '%s', found '%s'" % (value, tok[1]))
        self.i += 1
        return tok

    def expression(self):
        ops, const = self.term()
        while self.peek()[1] in ("+", "-"):
            self.take()
            o, c = self.term()
            ops, const = self._binary(ops, const, o, c)
        return ops, const

    def term(self):
        ops, const = self.unary()
        while self.peek()[1] in ("*", "/"):
            op = self.take()[1]
            o, c = self.unary()
            if op == "/" and not (const and c):
                self.divisions += 1
            ops, const = self._binary(ops, const, o, c)
        return ops, const

    @staticmethod
    def _binary(o1, c1, o2, c2):
        if c1 and c2:
            return 0, True
        return o1 + o2 + 1, False

    def unary(self):
        tok = self.peek()
        if tok[1] == "-":
            self.take()
            ops, const = self.unary()
            return (0, True) if const else (ops + 1, False)
        if tok[1] == "+":
            self.take()
            return self.unary()
        return self.primary()

    def primary(self):
        kind, value = self.take()
        if kind == "num":
            return 0, True
        if value == "(":
            result = self.expression()
            self.take(")")
            return result
        if kind == "id":
            if self.peek()[1] == "(":
                self.take("(")
                ops, const = 0, True
                if self.peek()[1] != ")":
                    while True:
                        o, c = self.expression()
                        ops, const = ops + o, const and c
                        if self.peek()[1] == ",":
                            self.take(",")
                            continue
                        break
                self.take(")")
                return (0, True) if const else (ops + 1, False)
            if self.peek()[1] == "[":
                self.take("[")
                self.expression()
                self.take("]")
                return 0, False
            return 0, value.startswith("M_")
        raise CountError("unexpected '%s'" % value)


def count_expression(expr, tally=None):
    """Operations in one expression; tally["div"] is increased by its counted divisions."""
    parser = _Parser(_tokens(expr))
    ops, _ = parser.expression()
    if parser.peek()[0] is not None:
        raise CountError("trailing text in '%s'" % expr)
    if tally is not None:
        tally["div"] = tally.get("div", 0) + parser.divisions
    return ops


def count_function(text, name, tally=None):
    """Operations in the body of function `name` of the C/C++ source `text`; when `tally` is a
    dict, tally["div"] receives the number of counted divisions (included in the total)."""
    body = re.sub(r"//[^\n]*", "", function_body(text, name))
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    total = 0
    for statement in body.split(";"):
        s = statement.strip()
        if not s or s.startswith("(void)"):
            continue
        if s.startswith("return "):
            total += count_expression(s[len("return "):], tally)
            continue
        m = re.match(r"^(?:const\s+)?(?:double\s+)?[A-Za-z_][A-Za-z0-9_]*(?:\[[^\]]*\])?\s*([-+*/]?)=(?!=)(.*)$",
                     s, re.S)
        if not m:
            raise CountError("not an assignment: '%s'" % s[:60])
        total += count_expression(m.group(2), tally) + (1 if m.group(1) else 0)
        if tally is not None and m.group(1) == "/":
            tally["div"] = tally.get("div", 0) + 1
    return total


def main(argv):
    if len(argv) != 3:
        print("usage: count_ops.py FILE FUNCTION", file=sys.stderr)
        return 2
    try:
        with open(argv[1]) as f:
            tally = {}
            total = count_function(f.read(), argv[2], tally)
            print("%d ops, of which %d divisions" % (total, tally.get("div", 0)))
    except (OSError, CountError) as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
