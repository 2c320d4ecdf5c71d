"""Nothing from a file can put a statement into an exported program.

The cell sits in a folder whose name holds a newline, a carriage return and a statement; the
program's file name holds another, or a keyword of the language.  An independent tokenizer per
language (below: comments to the end of the line, string literals) removes what the controller
ignores or treats as text; the marker must not be left in what it runs, and the program's own
name must be no keyword.
"""

from __future__ import annotations

import re
import shutil

import pytest

from rworld_cli.api import export_program
from tests.conftest import WORKCELLS

MARKER = "PWNED"
STATEMENTS = {  # a line each language would run
    "urscript": f"movej([0, 0, 0, 0, 0, 0], a=9, v=9) # {MARKER}",
    "krl": f"PTP {{A1 0}} ; {MARKER}",
    "rapid": f"MoveAbsJ [[0,0,0,0,0,0],[9E9]], v1000, fine, tool0; ! {MARKER}",
    "fanuc": f"  9:J P[1] 100% FINE ; {MARKER}[1]=ON ;",
}
FILES = {"urscript": ".script", "krl": ".src", "rapid": ".mod", "fanuc": ".ls"}
COMMENT = {"urscript": "#", "krl": ";", "rapid": "!"}
# the statements that name the program, and some words each language reserves (written here
# from the vendors' manuals, not taken from rworld)
NAMED = {
    "urscript": r"^\s*def\s+(\w+)\s*\(",
    "krl": r"^\s*DEF\s+(\w+)\s*\(",
    "rapid": r"^\s*MODULE\s+(\w+)",
    "fanuc": r"^/PROG\s+(\w+)",
}
KEYWORDS = {
    "urscript": {"def", "end", "movej", "movel", "thread", "while", "if", "sleep", "textmsg"},
    "krl": {"def", "end", "ptp", "lin", "if", "wait", "decl", "interrupt", "deffct", "main"},
    "rapid": {"module", "endmodule", "proc", "endproc", "main", "movel", "movej", "tooldata"},
    "fanuc": {"j", "l", "end", "main", "wait", "call", "jmp", "lbl", "pr", "do"},
}


def code_outside_comments_and_strings(text: str, language: str) -> str:
    """What the controller runs: every line without its comment and its string literals.  A
    FANUC TP line is ``N:  instruction ;``; a remark runs from ``!`` to the first ``;``, which
    ends the instruction - what follows it on the line would be read as the next one."""
    if language == "fanuc":
        kept = []
        for line in text.split("\n"):
            body = re.sub(r"^\s*\d+:\s*", "", line)
            if body.startswith("!"):
                body = body.split(";", 1)[1] if ";" in body else ""
            kept.append(body)
        return "\n".join(kept)
    out = []
    for line in text.split("\n"):  # controllers end lines at \n; a \r is part of the line
        kept, quoted = [], False
        for ch in line:
            if ch == '"':
                quoted = not quoted
                continue
            if not quoted and ch == COMMENT[language]:
                break
            if not quoted:
                kept.append(ch)
        out.append("".join(kept))
    return "\n".join(out)


def _export(tmp_path, folder: str, stem: str, language: str) -> str:
    """The puma560 cell in ``folder`` with pick_place as ``programs/<stem>.yaml``, exported:
    the program file's text."""
    cell = tmp_path / folder
    cell.parent.mkdir(parents=True, exist_ok=True)
    shutil.copytree(WORKCELLS / "puma560", cell)
    program = cell / "programs" / f"{stem}.yaml"
    shutil.copy(cell / "programs" / "pick_place.yaml", program)
    out = tmp_path / "out"
    export_program(str(cell), str(program), language, str(out))
    [written] = [p for p in out.iterdir() if p.suffix == FILES[language]]
    return written.read_text()


@pytest.mark.parametrize("language", ["urscript", "krl", "rapid", "fanuc"])
def test_folder_and_file_names_cannot_inject_statements(tmp_path, language):
    payload = f"x\n{STATEMENTS[language]}\r\n"
    text = _export(tmp_path, f"cell{payload}", f"pick{payload}", language)
    assert MARKER in text  # the payload is there, as text
    code = code_outside_comments_and_strings(text, language)
    # the marker may survive inside a name made of the file name's characters, never as a word
    # of its own: that would be the injected statement
    assert MARKER not in re.findall(r"[A-Za-z0-9_]+", code), code
    assert "\r" not in text


@pytest.mark.parametrize("language", ["urscript", "krl", "rapid", "fanuc"])
@pytest.mark.parametrize(
    "stem", ["movej", "end", "DEF", "PTP", "PROC", "MODULE", "ENDPROC", "main"]
)
def test_a_program_named_as_a_keyword_is_renamed_and_says_so(tmp_path, language, stem):
    text = _export(tmp_path, "cell", stem, language)
    [name] = re.findall(NAMED[language], text, flags=re.MULTILINE)
    assert name.lower() not in KEYWORDS[language]
    if stem.lower() in KEYWORDS[language]:
        assert f"'{name}' is program '{stem}'" in text  # renamed, and said
    else:
        assert name.lower() == stem.lower()
    if language == "urscript":  # it calls itself by that name at the end
        assert text.rstrip().endswith(f"{name}()")
