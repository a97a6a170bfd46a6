"""The sampler's output is a folder: a mesh-file name is refused before anything is written,
and the manifest gets the usual file permissions (written through the shared atomic writer)."""
import os
import stat

import pytest

from grammarkit_graph_sampler.output import VariantWriter


def test_a_mesh_file_name_is_refused_and_nothing_is_created(tmp_path):
    out = tmp_path / "castle.glb"
    with pytest.raises(FileExistsError, match="folder of variants"):
        VariantWriter(out, dedupe="histogram", seed=0)
    assert not out.exists()


def test_manifest_is_written_atomically_with_usual_permissions(tmp_path):
    writer = VariantWriter(tmp_path / "variants", dedupe="histogram", seed=0)
    writer.lines.append('{"id": "a"}')
    path = writer.flush()
    assert path.read_text() == '{"id": "a"}\n'
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask
    assert [p.name for p in path.parent.iterdir()] == ["manifest.jsonl"]  # no temp file left
