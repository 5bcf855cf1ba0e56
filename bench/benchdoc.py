"""The marked sections of docs/benchmarks.md: each bench script rewrites its own section, between
<!-- NAME begin --> and <!-- NAME end -->, and leaves the rest of the file (the other scripts'
sections and the notes written by hand) as it is."""
import pathlib

BENCHMARKS = pathlib.Path(__file__).resolve().parent.parent / "docs" / "benchmarks.md"


def write_section(name, lines, md=BENCHMARKS):
    """Replace section NAME of md by lines (which begin and end with its markers), or append it."""
    text = md.read_text() if md.exists() else "# Benchmarks\n"
    b, e = f"<!-- {name} begin -->", f"<!-- {name} end -->"
    body = "\n".join(lines).rstrip("\n")
    if b in text and e in text:
        text = text.split(b, 1)[0] + body + text.split(e, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + body + "\n"
    md.write_text(text)
    print(f"updated {md.name} ({name})")
