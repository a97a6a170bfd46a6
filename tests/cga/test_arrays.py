"""CGA arrays (docs/cga.md, "Arrays"): literals `[1, 2; 3, 4]`, `m[i]`, `m[i, j]`, index
ranges, `size`/`nRows`/`nColumns`, `findFirst` of an array, and `readStringTable` /
`readFloatTable` read while importing (looked up as CityEngine looks up assets). The snippets
are self-written after the constructs of Esri's Plant_Loader.cga (a metadata table read with
readStringTable, rows found with findFirst over a column range)."""
from __future__ import annotations

import numpy as np
import pytest

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.errors import DerivationError
from grammarkit.split.strings import array_value, cga_str

from ._cga_helpers import LOT, bbox, imported, line


def height(result) -> float:
    return float(bbox(grammarkit.derive(result.grammar, lot=LOT))[1][2])


def test_a_2d_literal_indexed_by_row_and_column_and_row_major():
    r = imported("const m = [4, 6; 8, 10]\nattr row = 1\n"
                 "Lot --> extrude(m[row, 1] + m[1] + size(m) + nRows(m) * 100 + nColumns(m) * 1000) X\n")
    assert "cgaArray(2, 2, 4, 6, 8, 10)" in r.text
    assert not r.diagnostics
    # m[1, 1] = 10, m[1] (row-major) = 6, 4 items, 2 rows, 2 columns
    assert height(r) == pytest.approx(10 + 6 + 4 + 200 + 2000, abs=0.01)


def test_items_keep_their_type():
    r = imported('const m = ["a", "bb"; "ccc", "dddd"]\nconst flags = [true, false]\n'
                 "flag(k) = case flags[k]: 10 else: 20\n"
                 "Lot --> extrude(len(m[1, 0]) + flag(0) + flag(1) * 100) X\n")
    assert height(r) == pytest.approx(3 + 10 + 2000, abs=0.01)


def test_an_attr_array_is_set_from_outside_like_any_value():
    r = imported("attr hs = [3, 5, 7]\nattr k = 0\nLot --> extrude(hs[k]) X\n")
    assert height(r) == pytest.approx(3, abs=0.01)
    g = r.grammar
    m = grammarkit.derive(g, lot=LOT, attrs={"hs": array_value(1, 3, [9.0, 1.0, 2.0])})
    assert bbox(m)[1][2] == pytest.approx(9, abs=0.01)


def test_str_of_an_array_and_rows_of_different_lengths():
    assert cga_str(array_value(2, 2, [1.0, 2.5, True, "x"])) == "[1,2.5;true,x]"
    text = "const m = [1, 2; 3]\nLot --> extrude(m[0]) X\n"
    r = translate_cga(text, filename="t.cga")
    warned = [d for d in r.diagnostics if d.severity == "warning"]
    assert warned and warned[0].span.line == 1 and "different lengths" in warned[0].message


def test_an_index_out_of_range_is_a_located_derivation_error():
    # an index known only while deriving (a constant one is already `grammarkit check`'s error)
    r = imported("const m = [1, 2]\nLot --> extrude(m[floor(rand(5, 6))]) X\n")
    with pytest.raises(DerivationError) as err:
        grammarkit.derive(r.grammar, lot=LOT)
    assert "array index 5 out of range" in str(err.value)
    # located in the CGA file: the index expression `m[...]` on line 2
    span = err.value.span
    assert (span.file, span.line, span.column) == ("t.cga", 2, 17)


def test_an_array_as_a_per_edge_operation_argument_stays_a_warning():
    text = "Lot --> setback([1, 2, 3, 4]) { all: A | remainder: B }\n"
    r = translate_cga(text, filename="t.cga")
    assert r.ok
    assert any(d.severity == "warning" and "array" in d.message for d in r.diagnostics)


PLANTS = """version "2023.0"
const Folder = "meta"
const table = readStringTable(Folder + "/trees.csv")
const heights = readFloatTable("meta/heights.csv")
const n = nRows(table) - 1
attr Name = "birch"
idx(nm) = findFirst(table[1:n, 0], nm)
@StartRule
Lot --> extrude(float(table[idx(Name) + 1, 1]) + heights[1, 1]) M.
"""


@pytest.fixture
def project(tmp_path):
    (tmp_path / "rules").mkdir()
    (tmp_path / "assets" / "meta").mkdir(parents=True)
    (tmp_path / "assets" / "meta" / "trees.csv").write_text("name,h\noak,12\nbirch,9\nfir,20\n")
    (tmp_path / "assets" / "meta" / "heights.csv").write_text("1;2\n3;0.5\n")
    (tmp_path / "rules" / "plants.cga").write_text(PLANTS)
    return tmp_path


def test_read_string_table_from_the_projects_assets(project):
    from grammarkit.cga.project import open_input

    proj = open_input(project / "rules" / "plants.cga")
    r = translate_cga(proj.rule_file, project=proj)
    assert r.ok, [d.message for d in r.diagnostics]
    assert 'cgaArray(4, 2, "name", "h", "oak", "12", "birch", "9", "fir", "20")' in r.text
    assert "cgaArray(2, 2, 1, 2, 3, 0.5)" in r.text  # `;`-separated, read as numbers
    # birch is row 2: 9 m, plus heights[1, 1] = 0.5
    assert np.isclose(bbox(grammarkit.derive(grammarkit.parse(r.text, filename=str(project / "p.grammar")),
                                             lot=LOT))[1][2], 9.5, atol=0.01)
    assert "Name" in line(r, "Lot")


def test_a_table_that_is_not_there_is_an_empty_array_and_a_located_warning(tmp_path):
    # Esri's Plant_Loader.cga in envelope2002.rpk: the metadata table is not in the package;
    # CityEngine reads it as an empty array and the building still generates
    text = ('const t = readStringTable("nowhere.csv")\nconst n = nRows(t) - 1\n'
            "Lot --> extrude(3 + size(t[1:n, 0])) X\n")
    r = translate_cga(text, filename=str(tmp_path / "t.cga"))
    assert r.ok, [d.message for d in r.diagnostics]
    warned = [d for d in r.diagnostics if d.severity == "warning"]
    assert warned and warned[0].span.line == 1 and "nowhere.csv" in warned[0].message
    assert "not found" in warned[0].message and "empty array" in warned[0].message
    assert "const t = cgaArray(0, 0)" in r.text
    assert height(r) == pytest.approx(3, abs=0.01)


def test_arrays_in_an_array_literal_are_spliced():
    # Plant_Loader's enum values: `[m[1:k, 0]; "\\n"; "PROXIES"; m[k+1:n, 0]]`
    r = imported('const m = [1, 2; 3, 4; 5, 6]\nconst col = [m[0:1, 0]; 9; m[2:2, 0]]\n'
                 "const wide = [m, m]\n"
                 "Lot --> extrude(col[1] + col[3] * 10 + nRows(col) * 100 + nColumns(wide) * 1000) X\n")
    # col = (1, 3, 9, 5): col[1] = 3, col[3] = 5, 4 rows; wide is 3 x 4
    assert height(r) == pytest.approx(3 + 50 + 400 + 4000, abs=0.01)


def test_an_array_const_as_an_operation_argument_is_a_located_warning_not_a_failed_check():
    text = "const d = [1, 2, 3, 4]\nLot --> setback(d) { all: A | remainder: B }\n"
    r = translate_cga(text, filename="t.cga")
    assert r.ok, [d.message for d in r.diagnostics]
    warned = [d for d in r.diagnostics if d.severity == "warning"]
    assert warned and (warned[0].span.line, warned[0].span.column) == (2, 9)
    assert "array d" in warned[0].message


def test_an_array_attr_gives_envelope_its_per_edge_values():
    literal = imported("Lot --> envelope(normal, 15, [5, 0, 0, 0], [45, 90, 90, 90]) E\n")
    named = imported("attr bases = [5, 0, 0, 0]\nLot --> envelope(normal, 15, bases, [45, 90, 90, 90]) E\n")
    assert "cgaVector(bases)" in line(named, "Lot")
    volumes = [grammarkit.derive(r.grammar, lot=LOT).mesh.volume for r in (literal, named)]
    assert volumes[1] == pytest.approx(volumes[0], rel=1e-9)
    assert volumes[0] == pytest.approx(20 * 16 * 15 - 20 * 10**2 / 2, rel=2e-3)
