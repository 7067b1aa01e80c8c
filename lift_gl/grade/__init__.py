"""`lift-gl grade`: statistical verdicts on a class's plugins (docs/grading.md).

    from lift_gl.grade import GradeSettings, grade
    grades = grade("class/", GradeSettings(reference="pt"), out="grades/")

Each submission renders each scene with independent seeds in a child process; its expectation
is tested against the reference's (lift_gl/consistency.py): pass, biased, error or timeout.
"""
from .grading import VERDICTS, Grade, find_submissions, grade
from .settings import GradeSettings

__all__ = ["VERDICTS", "Grade", "GradeSettings", "find_submissions", "grade"]
