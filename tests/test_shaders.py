"""The GLSL assembler: includes (also inside #if blocks), defines, errors mapped to file:line."""
from __future__ import annotations

import pytest

from lift_gl.errors import ShaderError
from lift_gl.gl.context import create_context
from lift_gl.shaders import assemble, compile_compute


def write(folder, name, text):
    path = folder / name
    path.write_text(text)
    return path


def test_include_inside_an_inactive_block_does_not_hide_a_later_include(tmp_path):
    write(tmp_path, "lib.glsl", "#ifndef LIB\n#define LIB\nfloat lib_value() { return 2.0; }\n#endif\n")
    main = write(tmp_path, "main.comp",
                 "layout(local_size_x = 1) in;\n#ifdef NEVER\n#include \"lib.glsl\"\n#endif\n"
                 "#include \"lib.glsl\"\nvoid main() { float x = lib_value(); }\n")
    compile_compute(create_context(), assemble(main)).release()


def test_errors_name_the_included_file_and_line(tmp_path):
    write(tmp_path, "lib.glsl", "// one\n// two\nfloat broken() { return missing_name; }\n")
    main = write(tmp_path, "main.comp", "layout(local_size_x = 1) in;\n#include \"lib.glsl\"\nvoid main() {}\n")
    with pytest.raises(ShaderError) as err:
        compile_compute(create_context(), assemble(main))
    assert err.value.path == str((tmp_path / "lib.glsl").resolve()) and err.value.line == 3
    assert "missing_name" in str(err.value)


def test_errors_after_an_include_keep_the_including_files_lines(tmp_path):
    write(tmp_path, "lib.glsl", "#ifndef LIB\n#define LIB\nfloat ok() { return 1.0; }\n#endif\n")
    main = write(tmp_path, "main.comp",
                 "layout(local_size_x = 1) in;\n#include \"lib.glsl\"\n#include \"lib.glsl\"\n"
                 "void main() { float y = not_declared; }\n")
    with pytest.raises(ShaderError) as err:
        compile_compute(create_context(), assemble(main))
    assert err.value.path.endswith("main.comp") and err.value.line == 4


def test_missing_include_and_cycles_are_clear_errors(tmp_path):
    main = write(tmp_path, "main.comp", "// first\n#include \"nowhere.glsl\"\n")
    with pytest.raises(ShaderError) as err:
        assemble(main)
    assert err.value.line == 2 and "nowhere.glsl" in str(err.value)
    write(tmp_path, "a.glsl", "#include \"b.glsl\"\n")
    write(tmp_path, "b.glsl", "#include \"a.glsl\"\n")
    with pytest.raises(ShaderError, match="includes itself"):
        assemble(write(tmp_path, "c.comp", "#include \"a.glsl\"\n"))


def test_defines_are_emitted_after_the_version_line():
    src = assemble("void main() {}\n", {"HAS_X": True, "COUNT": 3, "OFF": False})
    lines = src.text.splitlines()
    assert lines[0].startswith("#version")
    assert "#define HAS_X" in lines and "#define COUNT 3" in lines
    assert not any("OFF" in line for line in lines)
