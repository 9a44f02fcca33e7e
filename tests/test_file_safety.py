"""A user's files are never lost: no command writes over one of its inputs (one line, exit 2,
the input byte for byte), every output is written beside its target and moved into place only
when complete (a run that fails or is interrupted part-way leaves an existing target byte for
byte, and no partial file), and output paths are checked before any long work."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mjchar.bvh.bundled.assets import motion_path
from mjchar.bvh.io.files import OutputError, PendingFile, atomic_path, check_output, write_text
from mjchar.cli import main


def _refused(capsys, argv) -> str:
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.fixture
def clip(tmp_path) -> Path:
    dst = tmp_path / "clip.bvh"
    shutil.copy(motion_path("walk"), dst)
    return dst


def _no_partials(folder: Path) -> None:
    assert not [p.name for p in folder.iterdir() if ".partial" in p.name]


def test_convert_refuses_to_write_over_its_input(clip, capsys):
    before = clip.read_bytes()
    err = _refused(capsys, ["convert", clip, "-o", clip])
    assert "input" in err and "clip.bvh" in err
    assert clip.read_bytes() == before


def test_convert_of_a_bvh_named_xml_refuses_the_default_output(clip, capsys):
    """The default output is the input's stem + .xml: for a BVH called clip.xml that is the
    input itself."""
    named_xml = clip.with_suffix(".xml")
    clip.rename(named_xml)
    before = named_xml.read_bytes()
    _refused(capsys, ["convert", named_xml])
    assert named_xml.read_bytes() == before


def test_export_bvh_onto_the_motion_is_refused(clip, capsys):
    before = clip.read_bytes()
    err = _refused(capsys, ["run", "hand_of_god", "--motion", clip, "--export-bvh", clip])
    assert "--export-bvh" in err and "input" in err
    assert clip.read_bytes() == before


def test_render_onto_an_input_is_refused(tmp_path, capsys):
    from mjchar.bvh.bundled.assets import humanoid_path

    model = tmp_path / "model.mp4"  # a model oddly named .mp4: still an input
    shutil.copy(humanoid_path(), model)
    before = model.read_bytes()
    err = _refused(capsys, ["run", "static_balance", "--model", model, "--render", model])
    assert "--render" in err and "input" in err
    assert model.read_bytes() == before
    assert ".mp4" in _refused(capsys, ["run", "static_balance", "--render", "x.gif"])


@pytest.mark.parametrize("argv", [
    ["samcon", "{clip}", "-o", "{clip}"],
    ["trajopt", "{clip}", "-o", "{clip}"],
    ["samcon", "{clip}", "-o", "{missing}/out.npz"],
    ["trajopt", "--task", "jump", "-o", "{folder}"],
])
def test_optimisers_check_their_output_before_any_work(argv, clip, tmp_path, capsys):
    before = clip.read_bytes()
    argv = [a.format(clip=clip, missing=tmp_path / "nope", folder=tmp_path) for a in argv]
    _refused(capsys, argv)
    assert clip.read_bytes() == before


class _Interrupt:
    """Interrupt a run after ``n`` control steps (as Ctrl-C would)."""

    def __init__(self, n: int):
        self.n = n

    def __call__(self, *args, **kwargs):
        self.n -= 1
        if self.n <= 0:
            raise KeyboardInterrupt


def test_an_interrupted_run_leaves_an_existing_video_and_export(tmp_path, monkeypatch, capsys):
    pytest.importorskip("imageio_ffmpeg", reason="videos need the video extra")
    from mjchar.controllers.core.scenarios import shared as sim

    video, export = tmp_path / "old.mp4", tmp_path / "old.bvh"
    video.write_bytes(b"an old video the user keeps")
    export.write_bytes(b"an old export")
    recorder_record = sim.Recorder.record
    stop = _Interrupt(200)

    def record(self, character):
        stop()
        return recorder_record(self, character)

    monkeypatch.setattr(sim.Recorder, "record", record)
    code = main(["run", "static_balance", "--duration", "2", "--render", str(video),
                 "--export-bvh", str(export)])
    assert code == 130
    assert video.read_bytes() == b"an old video the user keeps"
    assert export.read_bytes() == b"an old export"
    _no_partials(tmp_path)


def test_an_interrupted_optimisation_leaves_an_existing_output(clip, tmp_path, monkeypatch):
    from mjchar.controllers.sampling import samcon

    out = tmp_path / "old.npz"
    out.write_bytes(b"the user's earlier trajectory")

    def interrupted(self, *a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(samcon.Samcon, "run", interrupted)
    assert main(["samcon", str(clip), "-o", str(out), "--samples", "8", "--duration", "0.2",
                 "--quiet"]) == 130
    assert out.read_bytes() == b"the user's earlier trajectory"
    _no_partials(tmp_path)


def test_atomic_writes_leave_the_target_on_failure(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("before")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("disk full")
    assert target.read_text() == "before"
    _no_partials(tmp_path)
    write_text(target, "after")
    assert target.read_text() == "after"
    pending = PendingFile(target)
    pending.tmp.write_text("never")
    pending.discard()
    assert target.read_text() == "after"
    _no_partials(tmp_path)


def test_check_output_names_the_problem(tmp_path, clip):
    with pytest.raises(OutputError, match="is an input"):
        check_output(clip, inputs=[clip])
    with pytest.raises(OutputError, match="does not exist"):
        check_output(tmp_path / "no" / "x.bvh")
    with pytest.raises(OutputError, match="is a folder"):
        check_output(tmp_path)
    with pytest.raises(OutputError, match=r"\.png"):
        check_output(tmp_path / "x.jpg", suffixes=(".png",))
    assert check_output(tmp_path / "fine.bvh", inputs=[clip, None]) == tmp_path / "fine.bvh"
