"""Nothing from a file can put a statement into an exported program.

The cell sits in a folder whose name holds a newline, a carriage return and a statement; the
program's file name holds another, or a keyword of the language.  An independent tokenizer per
language (below: comments to the end of the line, string literals) removes what the controller
ignores or treats as text; the marker must not be left in what it runs, and the program's own
name must be no keyword.  Then all eight languages, each read by its own rules from the written
bytes: Java's unicode escapes translated before javalang tokenizes (JLS 3.3), Python's coding
cookie honoured by ``ast.parse`` (DRL), VAL3's code out of its XML and CDATA, INFORM's comment
lines (issue 58).
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


# --- all eight languages: each one's own reading rules applied to the written bytes ----------

ALL_STATEMENTS = {
    **STATEMENTS,
    "inform": f"MOVJ C00000 VJ=100.00 {MARKER}",
    "drl": f"movej(posj(0, 0, 0, 0, 0, 0), vel=9, acc=9); {MARKER}()",
    "val3": f"movej(j{MARKER}, tTool, mNomSpeed)",
    "sunrise": f"{MARKER}();",
}
# what each controller's compiler or interpreter does to the bytes before it tokenizes
PAYLOADS = {
    "newline": "x\n{statement}\r\n",
    "java unicode escape": "x\\u000a{statement}\\u000d\\uu000a",
    "python coding cookie": "coding:utf-7 +AAo-{statement}",
    "cdata end": "x]]>]]><![CDATA[{statement}",
    "fanuc remark end": "x;{statement};",
}


def java_unicode_translated(text: str) -> str:
    """JLS 3.3: ``\\u+XXXX`` is the character, where the backslash is preceded by an even
    number of backslashes - as javac reads a file, before it tokenizes."""
    out, i = [], 0
    while i < len(text):
        if text[i] == "\\":
            run = len(re.match(r"\\*", text[i:]).group())
            found = re.match(r"\\u+([0-9a-fA-F]{4})", text[i + run - 1 :])
            if run % 2 == 1 and found:
                out.append("\\" * (run - 1) + chr(int(found.group(1), 16)))
                i += run - 1 + found.end()
                continue
            out.append("\\" * run)
            i += run
            continue
        out.append(text[i])
        i += 1
    return "".join(out)


def code_words(data: bytes, language: str) -> list[str]:
    """The names the controller would run: per language, its own reading of the bytes."""
    if language == "drl":  # Python: the bytes as the interpreter decodes them (coding cookie)
        import ast

        tree = ast.parse(data)
        return [n.id for n in ast.walk(tree) if isinstance(n, ast.Name)] + [
            n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)
        ]
    text = data.decode("ascii")  # every writer writes ASCII: a byte above 127 fails here
    if language == "sunrise":
        import javalang

        translated = java_unicode_translated(text)
        javalang.parse.parse(translated)  # the class is valid Java
        return [t.value for t in javalang.tokenizer.tokenize(translated)
                if isinstance(t, javalang.tokenizer.Identifier)]  # fmt: skip
    if language == "val3":
        from lxml import etree

        root = etree.fromstring(data)
        code = "\n".join(el.text or "" for el in root.iter("{*}Code"))
        code = "\n".join(
            re.sub(r'"[^"\n]*"', "", line.split("//", 1)[0]) for line in code.split("\n")
        )
        return re.findall(r"[A-Za-z0-9_]+", code)
    if language == "inform":  # a line starting with ' is a comment; "..." is text
        lines = text.replace("\r\n", "\n").split("\n")
        code = "\n".join(
            re.sub(r'"[^"\n]*"', "", line) for line in lines if not line.lstrip().startswith("'")
        )
        return re.findall(r"[A-Za-z0-9_]+", code)
    return re.findall(r"[A-Za-z0-9_]+", code_outside_comments_and_strings(text, language))


@pytest.fixture(scope="module")
def lbr_cell(tmp_path_factory):
    """KUKA's LBR iiwa 14 (Sunrise needs a 7-axis arm) as test_vendors builds it."""
    import yaml

    from rworld_cli.api import import_urdf
    from rworld_cli.schema.urdf import expand_xacro
    from tests.export.test_vendors import PACKAGES, PROGRAM_7, TIP, VENDORS, urdf_without_meshes

    folder = tmp_path_factory.mktemp("lbr")
    xacro, _, _, target = VENDORS["iiwa14"]
    expanded = folder / "iiwa.urdf"
    expanded.write_bytes(expand_xacro(xacro, xacro.name, [PACKAGES["iiwa14"]]))
    root = folder / "cell"
    imported = import_urdf(str(urdf_without_meshes(expanded, folder / "bare.urdf")), str(root))
    cell = yaml.safe_load((root / "cell.yaml").read_text())
    for joint in cell["devices"][0]["joints"]:
        joint["limits"]["acceleration"] = 10.0
    cell["devices"][0]["tcps"].append({"name": "tip", "parent": "tool0"})
    cell["frames"] = [{"name": "target"}]
    (root / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    poses = yaml.safe_load((root / "poses.yaml").read_text())
    poses["poses"].update({f"{imported.device}.tip": TIP, "target": target})
    (root / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    (root / "programs").mkdir()
    (root / "programs" / "pick_place.yaml").write_text(PROGRAM_7.format(device=imported.device))
    return root


EIGHT = ["urscript", "krl", "rapid", "fanuc", "inform", "val3", "drl", "sunrise"]
SUFFIX = {**FILES, "inform": ".JBI", "val3": ".pgx", "drl": ".drl", "sunrise": ".java"}


@pytest.mark.parametrize("payload", list(PAYLOADS))
@pytest.mark.parametrize("language", EIGHT)
def test_no_name_slot_injects_a_statement_in_any_language(tmp_path, lbr_cell, language, payload):
    """The payload in the cell's folder name and in the program's file name (the two slots a
    file system gives an attacker; every other name in a cell is an identifier the schema
    checks), read back by the language's own rules."""
    text = PAYLOADS[payload].format(statement=ALL_STATEMENTS[language])
    cell = tmp_path / f"cell{text}"
    cell.parent.mkdir(parents=True, exist_ok=True)
    shutil.copytree(lbr_cell if language == "sunrise" else WORKCELLS / "puma560", cell)
    program = cell / "programs" / f"pick{text}.yaml"
    shutil.copy(cell / "programs" / "pick_place.yaml", program)
    out = tmp_path / "out"
    export_program(str(cell), str(program), language, str(out))
    written = [p for p in out.rglob("*") if p.suffix == SUFFIX[language]]
    assert written
    for path in written:
        data = path.read_bytes()
        words = code_words(data, language)
        assert MARKER not in words, (path.name, data.decode("latin-1")[:600])
        if language == "drl":
            assert data.startswith(b"# -*- coding: utf-8 -*-\n")


@pytest.mark.parametrize("angle", ["30deg", "-120deg", "0deg", "179deg"])
def test_an_arm_angle_the_ik_cannot_hold_is_unreachable_not_a_crash(cli, lbr_cell, tmp_path, angle):
    """The outside report: a plain joint move of the LBR from its stretched zero pose with
    config: {arm_angle} crashed (LinAlgError, exit 3) for every value tried (issue 58)."""
    cell = tmp_path / "cell"
    shutil.copytree(lbr_cell, cell)
    import yaml

    device = yaml.safe_load((cell / "cell.yaml").read_text())["devices"][0]
    program = cell / "programs" / "plain.yaml"
    program.write_text(
        f"device: {device['name']}\nsteps:\n"
        f"  - move: {{to: target, config: {{arm_angle: {angle}}}}}\n"
    )
    result = cli(["simulate", str(cell), str(program)])
    assert result.exit_code in (0, 1), result.output
    if result.exit_code == 1:
        assert "with the arm angle" in result.output, result.output
