#!/usr/bin/env python3
"""The README's library code, extracted so CI compiles it (issue 33).

Every ```cpp block of the sections "Using the library" up to "How it works"
becomes one translation unit in OUT_DIR: the block's #include lines at file
scope, after a prelude that stands for the application (its GL loader: the
system's GL headers with prototypes), and the rest of the block as the body
of a function. Names a snippet uses but does not declare come from an HTML
comment on the line before its fence, invisible where the README is read:

    <!-- given: cdsm::Light spot; GLuint vbo = 0; -->

Usage: readme_snippets.py README.md OUT_DIR   (prints the files written)
"""
import os
import re
import sys

PRELUDE = """// Extracted from {readme}:{line} by scripts/readme_snippets.py.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>
#include <cdsm/cdsm.h>
"""


def blocks(text):
    """(first line number, given declarations, code lines) of each cpp block."""
    lines = text.split("\n")
    inside = False
    start_section = end_section = None
    for i, line in enumerate(lines):
        if line.startswith("## Using the library"):
            start_section = i
        elif start_section is not None and line.startswith("## How it works"):
            end_section = i
            break
    if start_section is None or end_section is None:
        sys.exit("readme_snippets: no 'Using the library' .. 'How it works' sections")
    out = []
    i = start_section
    while i < end_section:
        if lines[i].strip() == "```cpp":
            given = ""
            m = re.match(r"\s*<!--\s*given:(.*)-->\s*$", lines[i - 1])
            if m:
                given = m.group(1).strip()
            j = i + 1
            while j < end_section and lines[j].strip() != "```":
                j += 1
            if j >= end_section:
                sys.exit("readme_snippets: unterminated block at line %d" % (i + 1))
            out.append((i + 2, given, lines[i + 1:j]))
            i = j
        i += 1
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    readme, out_dir = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    found = blocks(open(readme, encoding="utf-8").read())
    if not found:
        sys.exit("readme_snippets: no cpp block found in %s" % readme)
    for n, (line, given, code) in enumerate(found):
        includes = [c for c in code if c.startswith("#include")]
        body = [c for c in code if not c.startswith("#include")]
        src = PRELUDE.format(readme=os.path.basename(readme), line=line)
        src += "\n".join(includes) + "\n\n"
        src += "void readme_snippet_%d() {\n" % n
        if given:
            src += "  " + given + "\n"
        src += "\n".join("  " + c if c else "" for c in body) + "\n}\n"
        path = os.path.join(out_dir, "readme_snippet_%d.cpp" % n)
        with open(path, "w", encoding="utf-8") as f:
            f.write(src)
        print(path)


if __name__ == "__main__":
    main()
