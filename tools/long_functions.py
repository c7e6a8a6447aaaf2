#!/usr/bin/env python3
"""long_functions.py - lists library functions longer than a limit (docs/design/cli.md,
"Library conventions": library functions stay under about 80 lines).

usage: tools/long_functions.py [--max N] [PATH ...]
  PATH: files or folders to scan (default: the library, i.e. src/ without src/cli,
  brdf/ and gpu/); every .c, .cpp and .h under a folder is read.
Prints "LINES  FILE:LINE  NAME" for each function over N (default 80) lines, longest
first, and exits 1 when there is one (0 when the rule holds), so a script or CI can
check it. A function's length counts its lines from the one holding its name to
the one holding its closing brace, both included.

How it finds functions (no C parser needed for this code base): comments, string
and character literals and preprocessor lines are blanked first (newlines kept, so
line numbers stay right); then a "{" at file scope opens a function when the text
before it, back to the previous ";", "}" or "{", ends in ")" (optionally followed
by qualifiers) and does not start a struct/union/enum or an initializer ("=").
`extern "C" {` and `namespace x {` blocks are transparent.
"""
import os
import re
import signal
import sys

DEFAULT_ROOTS = ["src", "brdf", "gpu"]
EXCLUDE = [os.path.join("src", "cli")]
EXTS = (".c", ".cpp", ".h")


def blank(text):
    """Returns text with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c in " \t":
            out.append(c)
            i += 1
            continue
        if line_start and c == "#":
            # preprocessor line, with backslash continuations
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        line_start = False
        if text.startswith("//", i):
            while i < n and text[i] != "\n":
                out.append(" ")
                i += 1
            continue
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * (j - i - 2) + c if j - i >= 2 else " ")
            i = j
            continue
        if c == "\n":
            line_start = True
        out.append(c)
        i += 1
    return "".join(out)


HEAD_END = re.compile(r"\)\s*(const|noexcept|override|final|\s)*$")
ATTR_END = re.compile(r"(\s*__attribute__\s*\(\((?:[^()]|\([^()]*\))*\)\))+$")
NAME = re.compile(r"([A-Za-z_~][A-Za-z0-9_:~]*)\s*\($")


def functions(path):
    """Yields (name, first_line, last_line) for each function defined in path."""
    with open(path, encoding="utf-8", errors="replace") as f:
        src = blank(f.read())
    stack = []          # per open brace: "T" transparent, "F" function, "O" other
    head_start = 0      # index after the last ";", "{" or "}" at file scope
    func = None         # (name, first_line) of the function being read
    for i, c in enumerate(src):
        if c == ";" and not [s for s in stack if s != "T"]:
            head_start = i + 1
        elif c == "{":
            scoped = [s for s in stack if s != "T"]
            if scoped:
                stack.append("O")
                continue
            head = src[head_start:i]
            kind = "O"
            if re.search(r"\b(extern\s*\"\s*\"|namespace(\s+\w+)?)\s*$", head):
                kind = "T"
            elif HEAD_END.search(head) and not re.search(r"\b(struct|union|enum)\b|=", head):
                # name: identifier before the "(" that matches the last ")" (trailing attributes dropped)
                sig = ATTR_END.sub("", head.rstrip())
                depth, j = 0, sig.rfind(")")
                while j >= 0:
                    if sig[j] == ")":
                        depth += 1
                    elif sig[j] == "(":
                        depth -= 1
                        if depth == 0:
                            break
                    j -= 1
                m = NAME.search(sig[: j + 1]) if j >= 0 else None
                if m:
                    kind = "F"
                    pos = head_start + m.start(1)
                    func = (m.group(1), src.count("\n", 0, pos) + 1)
            stack.append(kind)
            head_start = i + 1
        elif c == "}":
            kind = stack.pop() if stack else "O"
            if kind == "F" and func:
                yield func[0], func[1], src.count("\n", 0, i) + 1
                func = None
            if not [s for s in stack if s != "T"]:
                head_start = i + 1


def sources(roots):
    for root in roots:
        if os.path.isfile(root):
            yield root
            continue
        for d, subdirs, files in os.walk(root):
            subdirs[:] = sorted(s for s in subdirs if os.path.join(d, s) not in EXCLUDE)
            for name in sorted(files):
                if name.endswith(EXTS):
                    yield os.path.join(d, name)


def main(argv):
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)   # `| head` is not an error
    limit, roots = 80, []
    args = iter(argv)
    for a in args:
        if a == "--max":
            limit = int(next(args))
        elif a.startswith("-"):
            sys.stderr.write(__doc__)
            return 2
        else:
            roots.append(a)
    if not roots:
        os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
        roots = DEFAULT_ROOTS
    long = []
    for path in sources(roots):
        for name, first, last in functions(path):
            if last - first + 1 > limit:
                long.append((last - first + 1, path, first, name))
    for lines, path, first, name in sorted(long, key=lambda t: (-t[0], t[1])):
        print(f"{lines:5d}  {path}:{first}  {name}")
    return 1 if long else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
