"""Files read by the Python package: a named pipe where a scene, a particle file or a checkpoint
is expected is refused without waiting for a writer; relative paths are read against the
working directory (and a scene's particle files against the scene's folder); a checkpoint of
another format version is refused naming both versions. Each call that could block runs in a
child process under a time limit."""

import os
import subprocess
import sys
import textwrap

import pytest

import sparse_mpm as mpm

SCENE = """
[grid]
cell_size = [0.1, 0.1]
cells = [10, 10]
[time]
end = 0.01
[[bodies]]
name = "block"
material = { model = "neo_hookean", youngs_modulus = 1.0e5, poisson_ratio = 0.3 }
density = 1000.0
geometry = { rectangle = { min = [0.3, 0.3], max = [0.7, 0.7] } }
"""

PARTICLES = "x,y,mass,volume\n0.45,0.45,1.0,0.001\n0.55,0.45,1.0,0.001\n0.45,0.55,1.0,0.001\n0.55,0.55,1.0,0.001\n"


def in_child(code: str, cwd, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """`code` run by this interpreter in `cwd`; a call that waits for a writer fails the test by
    its timeout instead of hanging the test run."""
    try:
        return subprocess.run(
            [sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"waited {timeout} s: a read blocked\n{code}")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes")
def test_a_pipe_in_place_of_a_scene_particle_file_or_checkpoint_is_refused_without_waiting(tmp_path):
    os.mkfifo(tmp_path / "scene.toml")
    os.mkfifo(tmp_path / "state.ckpt")
    os.mkfifo(tmp_path / "particles.csv")
    (tmp_path / "with_file.toml").write_text(
        SCENE.replace('geometry = { rectangle = { min = [0.3, 0.3], max = [0.7, 0.7] } }', 'geometry = { file = "particles.csv" }')
    )
    for call in [
        "mpm.Simulation.from_scene('scene.toml')",
        "mpm.Simulation.from_checkpoint('state.ckpt')",
        "mpm.Simulation.from_scene('with_file.toml')",
    ]:
        done = in_child(
            f"""
            import sparse_mpm as mpm
            try:
                {call}
            except mpm.MpmError as e:
                print("refused:", e)
            """,
            tmp_path,
        )
        assert done.returncode == 0, done.stderr
        assert "refused:" in done.stdout and "regular file" in done.stdout, (call, done.stdout)


def test_relative_paths_are_read_against_the_working_directory_and_the_scene_folder(tmp_path):
    (tmp_path / "case").mkdir()
    (tmp_path / "case" / "particles.csv").write_text(PARTICLES)
    (tmp_path / "case" / "scene.toml").write_text(
        SCENE.replace('geometry = { rectangle = { min = [0.3, 0.3], max = [0.7, 0.7] } }', 'geometry = { file = "particles.csv" }')
    )
    (tmp_path / "other").mkdir()
    code = """
        import sparse_mpm as mpm
        for path in {paths}:
            sim = mpm.Simulation.from_scene(path)
            sim.step()
            sim.write_checkpoint("{ckpt}")
            again = mpm.Simulation.from_checkpoint("{ckpt}")
            print(path, sim.steps, again.steps, len(sim.particles()["x"]))
    """
    spellings = {
        tmp_path: ["case/scene.toml", "./case/scene.toml", "case/../case/scene.toml"],
        tmp_path / "case": ["scene.toml", "./scene.toml", "../case/scene.toml"],
        tmp_path / "other": ["../case/scene.toml", "../other/../case/scene.toml"],
    }
    for cwd, paths in spellings.items():
        done = in_child(code.format(paths=paths, ckpt="state.ckpt"), cwd)
        assert done.returncode == 0, done.stderr
        lines = done.stdout.splitlines()
        assert len(lines) == len(paths), done.stdout
        for line in lines:
            assert line.split()[1:] == ["1", "1", "4"], line


def test_a_checkpoint_of_another_format_version_is_refused_naming_both(tmp_path):
    sim = mpm.Simulation.from_toml(SCENE)
    sim.step()
    sim.write_checkpoint(tmp_path / "state.ckpt")
    data = bytearray((tmp_path / "state.ckpt").read_bytes())
    header = b"sparse-mpm checkpoint\n"
    assert data.startswith(header)
    version = int.from_bytes(data[len(header) : len(header) + 4], "little")
    data[len(header) : len(header) + 4] = (version + 1).to_bytes(4, "little")
    (tmp_path / "future.ckpt").write_bytes(bytes(data))
    with pytest.raises(mpm.MpmError) as refused:
        mpm.Simulation.from_checkpoint(tmp_path / "future.ckpt")
    message = str(refused.value)
    assert str(version + 1) in message and str(version) in message, message
