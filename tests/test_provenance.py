"""What provenance records: the behaviour hash that stales published runs, and the machine."""

import textwrap

from pih.records import provenance
from pih.records.provenance import behaviour_dump

MODULE = textwrap.dedent(
    '''
    """A rollout module."""
    from pih.scene_config import SceneConfig


    def spring_energy(k: float, dx: float) -> float:
        """E = k dx² / 2."""
        # the spring's potential
        return 0.5 * k * dx**2
    '''
)


def test_a_moved_module_or_a_reworded_comment_or_docstring_does_the_same():
    moved = MODULE.replace("from pih.scene_config import", "from pih.scene.config import")
    reworded = MODULE.replace("# the spring's potential", "# Hooke").replace("E = k", "Energy: k")
    relative = MODULE.replace("from pih.scene_config import", "from .config import")
    blank = MODULE.replace("    return", "\n\n    return")
    for same in (moved, reworded, relative, blank):
        assert behaviour_dump(same) == behaviour_dump(MODULE)


def test_a_changed_expression_or_name_does_something_else():
    for other in (
        MODULE.replace("0.5 * k", "0.25 * k"),
        MODULE.replace("dx**2", "dx**3"),
        MODULE.replace("import SceneConfig", "import SolverConfig"),
        MODULE.replace("def spring_energy", "def energy"),
        MODULE.replace('"""E = k dx² / 2."""', 'print("E")'),
    ):
        assert behaviour_dump(other) != behaviour_dump(MODULE)


def test_the_behaviour_hash_is_the_same_on_every_supported_python():
    """The dump leaves out empty fields as Python 3.13's ``ast.dump`` does (3.12's prints them):
    published runs made under one interpreter stay current under the other (CI tests both)."""
    import ast
    import sys

    source = (
        MODULE
        + "\ndef g(a, *, b=None) -> None:\n    match a:\n        case None:\n            return {}\n"
    )
    dump = behaviour_dump(source)
    assert "=[]" not in dump and "=None" not in dump.replace("value=None", "")
    assert "MatchSingleton(value=None)" in dump and "Constant(value=None)" in dump
    if sys.version_info >= (3, 13):
        tree = provenance._Behaviour().visit(ast.parse(source))
        assert dump == ast.dump(tree)


def test_the_rollout_hash_reads_every_rollout_module():
    assert len(provenance.rollout_code_hash()) == 64
    for name in provenance.ROLLOUT_MODULES:
        assert provenance.module_path(name).is_file(), name


def test_every_record_names_the_cpu_and_numpys_blas_kernel():
    machine = provenance.record("unit_test")["machine"]
    assert machine["cpu"]
    assert machine["blas"] and {"internal_api", "version", "architecture"} <= set(
        machine["blas"][0]
    )
    assert "machine" not in provenance.stable(provenance.record("unit_test"))
