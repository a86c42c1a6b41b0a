"""The function definitions of a C++ source file and their lengths in lines.

Written here because the tools that ship in Debian read too little of the C++ this project is
written in: pmccabe 2.8 stops at C++17 nested namespaces and takes `__attribute__((…))` and loop
headers for functions (it reports a "function" named `for`), and clang-tidy's
readability-function-size needs a full compile of every file (minutes on two cores). This is a
brace matcher: comments, literals and preprocessor lines are blanked (line numbers kept), and a
`{` opens a function body where the text before it, at namespace or class scope, ends with a
parameter list and its qualifiers (or a constructor's initialiser list). A function's length
runs from the line of its name to the line of its closing brace, both counted.
"""
import re

_QUALIFIERS = re.compile(
    r"\)\s*(?:(?:const|volatile|noexcept|override|final|mutable|&&|&)\s*|"
    r"noexcept\s*\([^()]*\)\s*|->\s*[\w:<>,\s*&]+?\s*)*$")
_SCOPE = re.compile(r"\b(namespace|extern)\b")
_CLASS = re.compile(r"\b(class|struct|union|enum)\b[^()=]*$")


def blank(text):
    """Comments, string and character literals and preprocessor lines as spaces; newlines kept."""
    out, i, n = [], 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#" :
            j = i
            while j < n and (text[j] != "\n" or text[j - 1] == "\\"):
                j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c == "/" and text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
            continue
        if c == "/" and text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c == "R" and text.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if m:
                end = text.find(")" + m.group(1) + '"', i)
                j = n if end < 0 else end + len(m.group(1)) + 2
                out.append(re.sub(r"[^\n]", " ", text[i:j]))
                i = j
                continue
        if c in "\"'":
            if c == "'" and i > 0 and (text[i - 1].isalnum()):
                out.append(c)  # a digit separator (1'000'000)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(" " * (min(j + 1, n) - i))
            i = j + 1
            continue
        out.append(c)
        at_line_start = c == "\n" or (at_line_start and c in " \t")
        i += 1
    return "".join(out)


def _signature_start(header):
    """Offset in header of the function's name: before the parameter list."""
    depth, k = 0, len(header) - 1
    # Leave out a constructor's initialiser list: the top-level ':' after the parameter list.
    m = re.search(r"\)\s*(?:noexcept\s*)?:(?!:)", header)
    end = m.start() + 1 if m else len(header)
    k = header.rfind(")", 0, end)
    while k >= 0:
        if header[k] == ")":
            depth += 1
        elif header[k] == "(":
            depth -= 1
            if depth == 0:
                break
        k -= 1
    k -= 1
    while k >= 0 and header[k].isspace():
        k -= 1
    while k >= 0 and (header[k].isalnum() or header[k] in "_:~<>=+-*/!&|[]^%"):
        k -= 1
    return k + 1


def functions(text):
    """[(first_line, lines, name)] of each function defined in the file, in order."""
    code = blank(text)
    line_of = [0] * (len(code) + 1)
    line = 1
    for i, c in enumerate(code):
        line_of[i] = line
        if c == "\n":
            line += 1
    line_of[len(code)] = line
    stack = []  # (kind, start offset of the function's name, or -1)
    header_from = 0
    found = []
    for i, c in enumerate(code):
        if c == ";":
            header_from = i + 1
        elif c == "{":
            header = code[header_from:i]
            outer = stack[-1][0] if stack else "scope"
            kind = "block"
            if outer in ("scope", "class"):
                stripped = header.strip()
                if _SCOPE.search(stripped) and "(" not in stripped:
                    kind = "scope"
                elif _CLASS.search(stripped):
                    kind = "class"
                elif re.search(r"\)\s*(?:noexcept\s*)?:(?!:).*[\w>]\s*$", stripped, re.S):
                    kind = "init"  # a brace-initialised member in an initialiser list
                elif _QUALIFIERS.search(stripped) and not re.search(r"=\s*\[", stripped) \
                        and not stripped.endswith("="):
                    kind = "function"
            start = header_from + _signature_start(header) if kind == "function" else -1
            if kind == "function" and re.match(r"\s*(if|for|while|switch|catch)\b",
                                               code[start:i]):
                kind, start = "block", -1
            stack.append((kind, start))
            if kind != "init":
                header_from = i + 1
        elif c == "}":
            if not stack:
                continue
            kind, start = stack.pop()
            if kind == "function":
                name = re.match(r"[\w:~<>=+\-*/!&|\[\]^%]+", code[start:]).group(0)
                first = line_of[start]
                found.append((first, line_of[i] - first + 1, name))
            if kind != "init":
                header_from = i + 1
    return sorted(found)
