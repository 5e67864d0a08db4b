"""Python law functions to C99: the exported C is the laws' own source, translated.

The step functions of :mod:`mfcontrol.laws` are written in a small subset of Python over
plain floats and the SoA columns ``CP[row, j]`` (parameters) and ``CS[row, j]`` (state) of
member ``j`` (numba compiles the same source for the engines). This module turns that
subset into C, one function at a time, reachable from a root function:

* a ``CP[row, j]`` read (or ``P[row]`` of the parameter tuple that
  :func:`mfcontrol.laws.recursive_ip.parameters` returns) becomes an element of the file's
  ``static const`` parameter table, which the compiler folds into the code; rows listed in
  ``fields`` (the tunable ones) are members of the parameter struct ``cp`` points to, which
  every function then takes first (``cp->kp``); rows listed in ``state_rows`` are read
  from the state instead (parameters a live controller rewrites);
* a ``CS[row, j]`` access becomes ``cs[row]``, ``cs`` being the controller's state array;
* ``j`` disappears; every function takes ``cs`` first;
* module constants (row numbers, mode codes) become literals;
* a function returning a tuple becomes a void function with one out-pointer per element;
* a variable is ``long`` where Python holds an int (``int()``, ``range``, ``%`` of ints)
  and the floating type otherwise.

Python's operation order is kept by full parenthesisation (compile without contraction:
``-ffp-contract=off``), so in double the C computes what numba computes, bit for bit.
Anything outside the subset raises :class:`TranslationError` naming the function and line.
"""

from __future__ import annotations

import ast
import inspect
import math
import re
import sys
import textwrap
import types
from dataclasses import dataclass, field
from typing import Literal, NoReturn, cast, overload

import numpy as np

INT, REAL, BOOL = "int", "real", "bool"
# kinds of the column arguments, which the C drops or replaces
CP, CS, J, PTUPLE = "CP", "CS", "j", "P"
_COLUMNS = (CP, CS, J, PTUPLE)
_C_KEYWORDS = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch",
    "typedef", "union", "unsigned", "void", "volatile", "while", "cs", "cp",
}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Mod: "%",
           ast.FloorDiv: "/"}
_CMPOPS = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">",
           ast.GtE: ">="}


class TranslationError(Exception):
    """The Python source uses something the C translation does not support."""


@dataclass
class Function:
    """One translated function: its C name, return kinds and text."""

    name: str
    returns: tuple[str, ...] | None  # None: void; one kind; several: out-pointers
    params: list[tuple[str, str]] = field(default_factory=list)  # (C name, kind)
    text: str = ""
    ptuple: bool = False  # returns the parameter tuple: calls to it vanish


@dataclass
class Options:
    """How the columns map to C for one export."""

    prefix: str
    real: str  # "double" or "float"
    param_table: str  # the C name of the static const parameter table
    state_rows: dict[int, int]  # parameter row -> state row holding it
    # a law function -> the function the C calls in its place (same bits, other cost)
    replace: dict = field(default_factory=dict)
    # tunable parameter row -> its member of the struct ``cp`` points to (None: every row
    # in the static table, the frozen build)
    fields: dict[int, str] | None = None

    def literal(self, value: float | int | bool) -> str:
        if isinstance(value, bool | np.bool_):
            return "1" if value else "0"
        if isinstance(value, int | np.integer):
            return str(int(value))
        value = float(value)
        if math.isnan(value):
            return f"(({self.real})NAN)"
        if math.isinf(value):
            return f"(({self.real})INFINITY)" if value > 0 else f"(-({self.real})INFINITY)"
        if self.real == "float":  # the float's own shortest repr: no double rounding
            f = np.float32(value)
            text = (np.format_float_positional(f, unique=True, trim="0")
                    if 1e-4 <= abs(value) < 1e7 else
                    np.format_float_scientific(f, unique=True, trim="-"))
            return text + "f"
        return repr(value)


def _merge(a: str, b: str) -> str:
    if a == b:
        return a
    if REAL in (a, b):
        return REAL
    return INT  # int and bool


class Translator:
    """Translate the functions reachable from the roots; :meth:`source` joins them."""

    def __init__(self, options: Options):
        self.options = options
        #: the module constants the C reads, by their C name (``PREFIX_MODULE_NAME``)
        self.constants: dict[str, int] = {}
        #: the C names of the parameter rows the C reads, by row
        self.param_names: dict[int, str] = {}
        #: the C names of the state rows the C reads by a constant (the first one read),
        #: by row: the memory's named view
        self.state_names: dict[int, str] = {}
        #: where each constant comes from: C name -> (module, Python name)
        self.origins: dict[str, tuple[types.ModuleType, str]] = {}
        self.done: dict[tuple, Function] = {}
        self.order: list[Function] = []  # callees before callers
        self._names: set[str] = set()
        self.helpers: set[str] = set()  # Python's integer % and // (floor), where used

    def function(self, fn, kinds: tuple[str, ...]) -> Function:
        """The C function for ``fn`` (a numba dispatcher or plain function) called with
        arguments of ``kinds``; translated once per signature."""
        py = getattr(fn, "py_func", fn)
        key = (py, kinds)
        if key not in self.done:
            self.done[key] = _FunctionTranslator(self, py, kinds).run()
            if not self.done[key].ptuple:
                self.order.append(self.done[key])
        return self.done[key]

    def unique_name(self, py) -> str:
        module = py.__module__.rsplit(".", 1)[-1]
        base = f"{self.options.prefix}_{module}_{py.__name__.lstrip('_')}"
        name, i = base, 2
        while name in self._names:
            name, i = f"{base}{i}", i + 1
        self._names.add(name)
        return name

    def source(self, roots: list[Function], names: bool = True) -> str:
        """The C of ``roots`` and every function they call (a function translated for
        argument kinds an earlier inference pass guessed is left out: C would reject an
        unused static function), after the :meth:`constant_names` unless ``names`` is
        False (the caller puts them in a header)."""
        used, todo = set(), [f.name for f in roots]
        by_name = {f.name: f for f in self.order}
        while todo:
            name = todo.pop()
            if name in used:
                continue
            used.add(name)
            todo += [n for n in by_name if re.search(rf"\b{n}\(", by_name[name].text)]
        funcs = [f for f in self.order if f.name in used]
        p, helpers = self.options.prefix, []
        if "mod" in self.helpers:
            helpers.append(f"/* Python's a % b: the sign of b */\n"
                           f"static long {p}_mod(long a, long b)\n{{\n"
                           "    long r = a % b;\n"
                           "    return (r != 0 && ((r < 0) != (b < 0))) ? r + b : r;\n}")
        if "floordiv" in self.helpers:
            helpers.append(f"/* Python's a // b: rounded down */\n"
                           f"static long {p}_floordiv(long a, long b)\n{{\n"
                           "    long q = a / b;\n"
                           "    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;\n}")
        protos = [self.prototype(f) + ";" for f in funcs]
        enum = [self.constant_names()] if self.constants and names else []
        return "\n\n".join(enum + helpers + ["\n".join(protos)] + [f.text for f in funcs])

    def constant_names(self) -> str:
        """The module constants the C reads, named as in the laws' Python (rows, counts,
        codes): ``PREFIX_MODULE_NAME`` is ``mfcontrol.laws.module.NAME``."""
        width = max(map(len, self.constants))
        rows = ",\n".join(f"    {name:<{width}} = {value}"
                          for name, value in sorted(self.constants.items()))
        return ("/* constants of mfcontrol.laws, named as there (PREFIX_MODULE_NAME is\n"
                " * mfcontrol.laws.module.NAME): the rows of the law's memory (an\n"
                " * application reads a state's as s.cs.row[PREFIX_MODULE_NAME]) and of its\n"
                f" * parameters, and the codes it compares with */\nenum {{\n{rows}\n}};")

    def ctype(self, kind: str) -> str:
        return {INT: "long", BOOL: "int", REAL: f"{self.options.prefix}_real"}[kind]

    def prototype(self, f: Function) -> str:
        params = [f"{self.options.prefix}_real *cs"]
        if self.options.fields is not None:
            params.insert(0, f"const {self.options.prefix}_params *cp")
        params += [f"{self.ctype(k)} {n}" for n, k in f.params]
        if f.returns is None or len(f.returns) == 1:
            ret = "void" if f.returns is None else self.ctype(f.returns[0])
        else:
            ret = "void"
            params += [f"{self.ctype(k)} *out{i}" for i, k in enumerate(f.returns)]
        return f"static {ret} {f.name}({', '.join(params)})"


class _FunctionTranslator:
    def __init__(self, tr: Translator, py, kinds: tuple[str, ...]):
        self.tr = tr
        self.opt = tr.options
        self.py = py
        self.globals = py.__globals__
        source = textwrap.dedent(inspect.getsource(py))
        # the source of a function is its definition
        self.node = cast(ast.FunctionDef, ast.parse(source).body[0])
        self.line0 = py.__code__.co_firstlineno - 1
        args = [a.arg for a in self.node.args.args]
        if len(args) != len(kinds):
            self.fail(self.node, f"called with {len(kinds)} arguments, takes {len(args)}")
        self.args = dict(zip(args, kinds, strict=True))
        self.locals: dict[str, str] = {}
        self.returns: tuple[str, ...] | None = None
        self.returns_seen = False
        self.ptuple = False
        self.tmp = 0
        # what every function takes first: the state, after the parameter struct when
        # there is one
        self.columns = ["cs"] if self.opt.fields is None else ["cp", "cs"]

    # -- errors -------------------------------------------------------------------------
    def fail(self, node, what: str) -> NoReturn:
        line = self.line0 + getattr(node, "lineno", 1)
        raise TranslationError(f"{self.py.__module__}.{self.py.__name__} (line {line}): "
                               f"{what}")

    # -- driver -------------------------------------------------------------------------
    def run(self) -> Function:
        body = [s for s in self.node.body
                if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
        # infer the variables' kinds to a fixed point (a variable first int may later hold
        # a float, known only a pass later); kinds only widen, so it comes
        for _ in range(100):
            before = dict(self.locals), dict(self.args), self.returns
            self.lines: list[str] = []
            self.tmp = 0
            self.block(body, 1)
            if (dict(self.locals), dict(self.args), self.returns) == before:
                break
        else:  # pragma: no cover (kinds form a finite lattice)
            self.fail(self.node, "the kinds of its variables do not settle")
        f = Function(self.tr.unique_name(self.py), self.returns, ptuple=self.ptuple)
        f.params = [(self.cname(a), k) for a, k in self.args.items() if k not in _COLUMNS]
        if self.ptuple:
            return f
        self.lines = []
        self.tmp = 0
        self.block(body, 1)
        body_text = "\n".join(self.lines)
        decls, unused = [], [n for n in self.columns + [n for n, _ in f.params]
                             if not _read(n, body_text)]
        for name, kind in sorted(self.locals.items()):
            c = self.cname(name)
            decls.append(f"    {self.tr.ctype(kind)} {c} = 0;")
            if not _read(c, body_text):  # set but never read (an unpacked value unused)
                unused.append(c)
        # declarations first (-Wdeclaration-after-statement), then the silenced names
        decls += [f"    (void){n};" for n in unused]
        f.text = (f"/* {self.py.__module__}.{self.py.__name__} */\n"
                  + self.tr.prototype(f) + "\n{\n" + "\n".join(decls + self.lines) + "\n}")
        return f

    def cname(self, name: str) -> str:
        return name + "_" if name in _C_KEYWORDS else name

    def local(self, name: str, kind: str):
        if name in self.args:
            if self.args[name] in _COLUMNS:
                self.fail(self.node, f"assigns the column argument {name}")
            # a parameter assigned: C passes by value, so it may be assigned as in Python
            self.args[name] = _merge(self.args[name], kind)
            return
        self.locals[name] = _merge(self.locals.get(name, kind), kind)

    def as_kind(self, code: str, kind: str, want: str | None) -> str:
        """``code`` of ``kind`` converted where C would convert it implicitly to ``want``:
        the same value, said explicitly (``-Wconversion``)."""
        if want == REAL and kind in (INT, BOOL):
            return f"(({self.tr.ctype(REAL)}){code})"
        return code

    def temp(self, kind: str) -> str:
        self.tmp += 1
        name = f"tmp{self.tmp}_"
        self.locals[name] = kind
        return name

    # -- statements -----------------------------------------------------------------------
    def emit(self, depth: int, text: str):
        self.lines.append("    " * depth + text)

    def block(self, stmts, depth: int):
        for s in stmts:
            self.statement(s, depth)

    def statement(self, s, depth: int):
        if isinstance(s, ast.Assign):
            if len(s.targets) != 1:
                self.fail(s, "chained assignment")
            self.assign(s.targets[0], s.value, depth, s)
        elif isinstance(s, ast.AugAssign):
            op = _BINOPS.get(type(s.op))
            if op is None:
                self.fail(s, f"operator {type(s.op).__name__}")
            value = ast.BinOp(left=_load(s.target), op=s.op, right=s.value)
            ast.copy_location(value, s)
            self.assign(s.target, value, depth, s)
        elif isinstance(s, ast.If):
            self.emit(depth, f"if ({_bare(self.expr(s.test)[0])}) {{")
            self.block(s.body, depth + 1)
            while len(s.orelse) == 1 and isinstance(s.orelse[0], ast.If):  # elif
                s = s.orelse[0]
                self.emit(depth, f"}} else if ({_bare(self.expr(s.test)[0])}) {{")
                self.block(s.body, depth + 1)
            if s.orelse:
                self.emit(depth, "} else {")
                self.block(s.orelse, depth + 1)
            self.emit(depth, "}")
        elif isinstance(s, ast.For):
            self.loop(s, depth)
        elif isinstance(s, ast.Return):
            self.ret(s, depth)
        elif isinstance(s, ast.Expr):
            if isinstance(s.value, ast.Constant):
                return
            if not isinstance(s.value, ast.Call):
                self.fail(s, "an expression statement that is not a call")
            self.emit(depth, self.call(s.value, statement=True) + ";")
        elif isinstance(s, ast.Pass):
            pass
        elif isinstance(s, ast.Break | ast.Continue):
            self.emit(depth, "break;" if isinstance(s, ast.Break) else "continue;")
        else:
            self.fail(s, f"statement {type(s).__name__}")

    def assign(self, target, value, depth: int, s):
        if isinstance(target, ast.Tuple):
            names = target.elts
            if isinstance(value, ast.Tuple):
                if len(value.elts) != len(names):
                    self.fail(s, "tuple assignment of unequal lengths")
                held = []
                for v in value.elts:  # Python evaluates the whole right side first
                    code, kind = self.expr(v)
                    t = self.temp(kind)
                    self.emit(depth, f"{t} = {code};")
                    held.append((t, kind))
                for tgt, (t, kind) in zip(names, held, strict=True):
                    self.store(tgt, t, kind, depth, s)
                return
            if isinstance(value, ast.Call):
                callee, args = self.callee(value)
                if callee.returns is None or len(callee.returns) != len(names):
                    self.fail(s, f"unpacks {len(names)} values from {callee.name}")
                temps = [self.temp(k) for k in callee.returns]
                ptrs = ", ".join(f"&{t}" for t in temps)
                self.emit(depth, f"{callee.name}({', '.join(self.columns + args + [ptrs])});")
                for tgt, t, k in zip(names, temps, callee.returns, strict=True):
                    if not (isinstance(tgt, ast.Name) and tgt.id == "_"):
                        self.store(tgt, t, k, depth, s)
                return
            self.fail(s, "tuple assignment from something other than a tuple or a call")
        code, kind = self.expr(value)
        if kind == PTUPLE:
            if not isinstance(target, ast.Name):
                self.fail(s, "the parameter tuple assigned to a non-name")
            self.args[target.id] = PTUPLE
            return
        self.store(target, code, kind, depth, s)

    def store(self, target, code: str, kind: str, depth: int, s):
        if isinstance(target, ast.Name):
            self.local(target.id, kind)
            held = self.args.get(target.id, self.locals.get(target.id))
            self.emit(depth, f"{self.cname(target.id)} = {self.as_kind(code, kind, held)};")
        elif isinstance(target, ast.Subscript):
            ref, col = self.subscript(target)
            if col != CS:
                self.fail(s, "writes a parameter")
            self.emit(depth, f"{ref} = {self.as_kind(code, kind, REAL)};")
        else:
            self.fail(s, f"assignment to {type(target).__name__}")

    def loop(self, s: ast.For, depth: int):
        it = s.iter
        if not (isinstance(it, ast.Call) and isinstance(it.func, ast.Name)
                and it.func.id == "range" and isinstance(s.target, ast.Name) and not s.orelse):
            self.fail(s, "a loop other than `for name in range(...)`")
        args = [self.expr(a) for a in it.args]
        step = 1
        if len(args) == 3:
            step = self.constant(it.args[2])
            if not isinstance(step, int) or step == 0:
                self.fail(s, "a range step that is not a non-zero integer constant")
        start, stop = ("0", args[0][0]) if len(args) == 1 else (args[0][0], args[1][0])
        var = self.cname(s.target.id)
        self.local(s.target.id, INT)
        end = self.temp(INT)  # Python evaluates the bounds once
        # a hidden counter: the body may rebind the variable, and after the loop it holds
        # the last value taken, as in Python
        count = self.temp(INT)
        self.emit(depth, f"{end} = {stop};")
        cmp = "<" if step > 0 else ">"
        self.emit(depth, f"for ({count} = {start}; {count} {cmp} {end}; {count} += {step}) {{")
        self.emit(depth + 1, f"{var} = {count};")
        self.block(s.body, depth + 1)
        self.emit(depth, "}")

    def ret(self, s: ast.Return, depth: int):
        value = s.value
        if value is None:
            self.set_returns(None, s)
            self.emit(depth, "return;")
            return
        if isinstance(value, ast.Tuple):
            codes = [self.expr(v) for v in value.elts]
            self.set_returns(tuple(k for _, k in codes), s)
            if len(codes) == 1:
                want = self.returns[0] if self.returns else None
                self.emit(depth, f"return {self.as_kind(*codes[0], want)};")
                return
            # the out-pointers point at the caller's variables, never at these locals
            for i, (code, kind) in enumerate(codes):
                want = self.returns[i] if self.returns else None
                self.emit(depth, f"*out{i} = {self.as_kind(code, kind, want)};")
            self.emit(depth, "return;")
            return
        if (isinstance(value, ast.Call) and isinstance(value.func, ast.Name)
                and value.func.id == "to_fixed_tuple"):
            self.ptuple = True  # the member's parameter column as a tuple
            return
        if isinstance(value, ast.Call) and self._builtin(value, self.resolve(value.func)) is None:
            callee, args = self.callee(value)
            if callee.ptuple:
                self.ptuple = True
                return
            if callee.returns is not None and len(callee.returns) > 1:
                self.set_returns(callee.returns, s)
                outs = [f"out{i}" for i in range(len(callee.returns))]
                self.emit(depth, f"{callee.name}({', '.join(self.columns + args + outs)});")
                self.emit(depth, "return;")
                return
        code, kind = self.expr(value)
        self.set_returns((kind,), s)
        want = self.returns[0] if self.returns else None
        self.emit(depth, f"return {self.as_kind(code, kind, want)};")

    def set_returns(self, kinds, s):
        if not self.returns_seen:
            self.returns_seen = True
            self.returns = kinds
            return
        if (self.returns is None) != (kinds is None):
            self.fail(s, "returns a value on one path and none on another")
        if kinds is None:
            return
        if len(kinds) != len(self.returns):
            self.fail(s, "returns tuples of different lengths")
        self.returns = tuple(_merge(a, b) for a, b in zip(self.returns, kinds, strict=True))

    # -- expressions ----------------------------------------------------------------------
    def resolve(self, node):
        """The Python object a global name or module attribute refers to, or None."""
        if isinstance(node, ast.Name):
            if node.id in self.args or node.id in self.locals:
                return None
            if node.id in self.globals:
                return self.globals[node.id]
            import builtins
            return getattr(builtins, node.id, None)
        if isinstance(node, ast.Attribute):
            base = self.resolve(node.value)
            if isinstance(base, types.ModuleType):
                return getattr(base, node.attr)
        return None

    def constant(self, node):
        """The value of an expression of constants only, or None."""
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float | bool):
            return node.value
        if isinstance(node, ast.Name | ast.Attribute):
            value = self.resolve(node)
            if isinstance(value, int | float | bool | np.integer | np.floating):
                return value
            return None
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            v = self.constant(node.operand)
            return None if v is None else -v
        if isinstance(node, ast.BinOp) and type(node.op) in (ast.Add, ast.Sub, ast.Mult):
            a, b = self.constant(node.left), self.constant(node.right)
            if a is None or b is None:
                return None
            return {ast.Add: a + b, ast.Sub: a - b, ast.Mult: a * b}[type(node.op)]
        return None

    def named(self, node, value) -> str | None:
        """The C name of a module constant of the laws that ``node`` reads (an integer
        row, count or code, by its Python name), registered for the file's enum; None for
        anything else (a literal, an expression, a float)."""
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            return None
        if isinstance(node, ast.Name):
            module, attr = sys.modules[self.py.__module__], node.id
        elif isinstance(node, ast.Attribute) and isinstance(
                base := self.resolve(node.value), types.ModuleType):
            module, attr = base, node.attr
        else:
            return None
        name = f"{self.opt.prefix}_{module.__name__.rsplit('.', 1)[-1]}_{attr}".upper()
        if self.tr.constants.setdefault(name, int(value)) != int(value):  # pragma: no cover
            self.fail(node, f"{name} names two values")
        self.tr.origins[name] = (module, attr)
        return name

    def expr(self, node) -> tuple[str, str]:
        value = self.constant(node)
        if value is not None:
            kind = BOOL if isinstance(value, bool) else (
                INT if isinstance(value, int | np.integer) else REAL)
            return self.named(node, value) or self.opt.literal(value), kind
        if isinstance(node, ast.Name):
            if node.id in self.args:
                return self.cname(node.id), self.args[node.id]
            if node.id in self.locals:
                return self.cname(node.id), self.locals[node.id]
            self.fail(node, f"name {node.id!r} is neither local nor a numeric constant")
        if isinstance(node, ast.Attribute):
            obj = self.resolve(node)
            if isinstance(obj, float) and math.isnan(obj):
                return self.opt.literal(obj), REAL
            self.fail(node, f"attribute {ast.unparse(node)}")
        if isinstance(node, ast.Subscript):
            ref, _ = self.subscript(node)
            return ref, REAL
        if isinstance(node, ast.BinOp):
            return self.binop(node)
        if isinstance(node, ast.UnaryOp):
            code, kind = self.expr(node.operand)
            if isinstance(node.op, ast.USub):
                return (f"(-({code}))" if code.startswith("-") else f"(-{code})"), kind
            if isinstance(node.op, ast.Not):
                return f"(!{code})", BOOL
            self.fail(node, f"unary {type(node.op).__name__}")
        if isinstance(node, ast.Compare):
            parts, left = [], node.left
            for op, right in zip(node.ops, node.comparators, strict=True):
                c = _CMPOPS.get(type(op))
                if c is None:
                    self.fail(node, f"comparison {type(op).__name__}")
                (a, ka), (b, kb) = self.expr(left), self.expr(right)
                if REAL in (ka, kb):  # an enum constant against a real: said explicitly
                    a, b = self.as_kind(a, ka, REAL), self.as_kind(b, kb, REAL)
                parts.append(f"({a} {c} {b})")
                left = right
            return ("(" + " && ".join(parts) + ")" if len(parts) > 1 else parts[0]), BOOL
        if isinstance(node, ast.BoolOp):
            joiner = " && " if isinstance(node.op, ast.And) else " || "
            operands = [self.expr(v) for v in node.values]
            if any(k != BOOL for _, k in operands):
                # Python's `a or b` is a or b itself, C's is 0 or 1
                self.fail(node, "`and`/`or` of values that are not comparisons")
            return "(" + joiner.join(c for c, _ in operands) + ")", BOOL
        if isinstance(node, ast.IfExp):
            c = self.expr(node.test)[0]
            a, ka = self.expr(node.body)
            b, kb = self.expr(node.orelse)
            k = _merge(ka, kb)
            return f"({c} ? {self.as_kind(a, ka, k)} : {self.as_kind(b, kb, k)})", k
        if isinstance(node, ast.Call):
            return self.call(node)
        self.fail(node, f"expression {type(node).__name__}")

    def binop(self, node) -> tuple[str, str]:
        op = _BINOPS.get(type(node.op))
        if op is None:
            self.fail(node, f"operator {type(node.op).__name__}")
        a, ka = self.expr(node.left)
        b, kb = self.expr(node.right)
        ints = ka != REAL and kb != REAL
        if not ints:  # C converts the integer side: said explicitly
            a, b = self.as_kind(a, ka, REAL), self.as_kind(b, kb, REAL)
        if isinstance(node.op, ast.Div):
            # true division: at least one side in floating point
            if ints:
                a = f"(({self.tr.ctype(REAL)}){a})"
            return f"({a} / {b})", REAL
        if isinstance(node.op, ast.Mod | ast.FloorDiv):
            if not ints:
                self.fail(node, "% or // of floating-point values")
            # C truncates where Python floors: the helpers give Python's results
            helper = "mod" if isinstance(node.op, ast.Mod) else "floordiv"
            self.tr.helpers.add(helper)
            return f"{self.opt.prefix}_{helper}({a}, {b})", INT
        return f"({a} {op} {b})", INT if ints else REAL

    def subscript(self, node) -> tuple[str, str]:
        base = node.value
        if not isinstance(base, ast.Name) or base.id not in self.args:
            self.fail(node, f"subscript of {ast.unparse(base)}")
        col = self.args[base.id]
        idx = node.slice
        if col in (CP, CS):
            if not (isinstance(idx, ast.Tuple) and len(idx.elts) == 2
                    and isinstance(idx.elts[1], ast.Name)
                    and self.args.get(idx.elts[1].id) == J):
                self.fail(node, f"{base.id} indexed other than [row, j]")
            row = idx.elts[0]
        elif col == PTUPLE:
            row = idx
        else:
            self.fail(node, f"subscript of the {col} argument {base.id}")
        if col == CS:
            code = self.expr(row)[0]
            if code in self.tr.constants:  # a row read by its name
                self.tr.state_names.setdefault(self.tr.constants[code], code)
            return f"cs[{code}]", CS
        value = self.constant(row)
        if value is None:
            self.fail(node, "a parameter row that is not a constant")
        row_n = int(value)
        if row_n in self.opt.state_rows:
            return f"cs[{self.opt.state_rows[row_n]}]", CS
        if self.opt.fields is not None and row_n in self.opt.fields:
            return f"cp->{self.opt.fields[row_n]}", CP
        name = self.named(row, value)
        if name is None:
            return f"{self.opt.param_table}[{row_n}]", CP
        self.tr.param_names[row_n] = name
        return f"{self.opt.param_table}[{name}]", CP

    def callee(self, node) -> tuple[Function, list[str]]:
        fn = self.resolve(node.func)
        fn = self.opt.replace.get(fn, fn)
        if fn is None or not (hasattr(fn, "py_func") or inspect.isfunction(fn)):
            self.fail(node, f"call of {ast.unparse(node.func)}")
        if node.keywords:
            self.fail(node, "keyword arguments")
        kinds, codes = [], []
        for a in node.args:
            if isinstance(a, ast.Name) and self.args.get(a.id) in _COLUMNS:
                kinds.append(self.args[a.id])
                continue
            code, kind = self.expr(a)
            kinds.append(kind)
            if kind not in _COLUMNS:
                codes.append(code)
        return self.tr.function(fn, tuple(kinds)), codes

    # the C of a call and its kind; a statement's is its code alone
    @overload
    def call(self, node, statement: Literal[False] = ...) -> tuple[str, str]: ...
    @overload
    def call(self, node, statement: Literal[True]) -> str: ...
    def call(self, node, statement: bool = False) -> tuple[str, str] | str:
        fn = self.resolve(node.func)
        builtin = self._builtin(node, fn)
        if builtin is not None:
            if statement:  # every builtin translated computes a value and nothing else
                self.fail(node, f"{ast.unparse(node.func)}() as a statement: its value is "
                          "unused")
            return builtin
        callee, args = self.callee(node)
        if callee.ptuple:
            return "", PTUPLE
        if callee.returns is not None and len(callee.returns) > 1:
            if not statement:
                self.fail(node, f"uses the tuple {callee.name} returns as one value")
            temps = [self.temp(k) for k in callee.returns]
            args = args + [f"&{t}" for t in temps]
        code = f"{callee.name}({', '.join(self.columns + args)})"
        if statement:
            return code
        if callee.returns is None:
            self.fail(node, f"uses the result of {callee.name}, which returns nothing")
        return code, callee.returns[0]

    def _builtin(self, node, fn):
        args = node.args
        if fn in (max, min, abs, math.fabs, np.abs) and any(
                isinstance(n, ast.Call) for a in args for n in ast.walk(a)):
            # the C evaluates an argument twice
            self.fail(node, f"a call inside {ast.unparse(node.func)}(): assign it first")
        if fn is int:
            return f"((long)({self.expr(args[0])[0]}))", INT
        if fn is float:
            return f"(({self.tr.ctype(REAL)})({self.expr(args[0])[0]}))", REAL
        if fn in (max, min) and len(args) == 2:
            (a, ka), (b, kb) = self.expr(args[0]), self.expr(args[1])
            # Python keeps the first unless the second compares greater (smaller): the
            # same result for NaN and signed zeros
            c = ">" if fn is max else "<"
            k = _merge(ka, kb)
            a, b = self.as_kind(a, ka, k), self.as_kind(b, kb, k)
            return f"(({b} {c} {a}) ? {b} : {a})", k
        if fn in (math.isnan, np.isnan):
            return f"isnan({self.expr(args[0])[0]})", BOOL
        if fn in (math.isfinite, np.isfinite):
            return f"isfinite({self.expr(args[0])[0]})", BOOL
        if fn in (math.sqrt, np.sqrt):
            suffix = "f" if self.opt.real == "float" else ""
            return f"sqrt{suffix}({self.expr(args[0])[0]})", REAL
        if fn in (math.exp, np.exp):
            # the C library's exp, as numba calls the process's: the same bits where both
            # are the same library (glibc's is correctly rounded in nearly every case)
            suffix = "f" if self.opt.real == "float" else ""
            return f"exp{suffix}({self.expr(args[0])[0]})", REAL
        if fn in (abs, math.fabs, np.abs):
            suffix = "f" if self.opt.real == "float" else ""
            code, kind = self.expr(args[0])
            return (f"fabs{suffix}({code})", REAL) if kind == REAL else (
                f"(({code} < 0) ? -({code}) : {code})", INT)
        return None


def _bare(cond: str) -> str:
    """``cond`` without the parentheses around it: ``if ((a == b))`` is clang's
    -Wparentheses-equality warning."""
    if cond.startswith("(") and cond.endswith(")"):
        depth = 0
        for i, ch in enumerate(cond):
            depth += ch == "("
            depth -= ch == ")"
            if depth == 0:
                return cond[1:-1] if i == len(cond) - 1 else cond
    return cond


def _read(name: str, text: str) -> bool:
    """Whether C ``text`` reads ``name`` (uses it other than as an assignment's target)."""
    uses = len(re.findall(rf"\b{name}\b", text))
    stores = len(re.findall(rf"^\s*{name} = ", text, flags=re.M))
    return uses > stores


def _load(target):
    """``target`` read back (the left side of an augmented assignment)."""
    node = ast.parse(ast.unparse(target), mode="eval").body
    return ast.copy_location(node, target)
