"""Hostile formulas: each would run code, read files or hang if a formula were evaluated.

``sentinel(path)`` strings try to create the file ``path``; tests check it never appears.
"""


def hostile(sentinel):
    """At least 30 strings that the formula grammar must refuse (``sentinel`` is a file path)."""
    s = str(sentinel)
    return [
        f"__import__('os').system('touch {s}')",
        f"__import__('pathlib').Path('{s}').touch()",
        f"open('{s}', 'w').write('x')",
        f"exec(\"open('{s}','w')\")",
        f"eval(\"open('{s}','w')\")",
        f"exp(__import__('os').system('touch {s}'))",
        f"x + (lambda: open('{s}', 'w'))()",
        f"[open('{s}', 'w') for _ in (1,)]",
        f"{{open('{s}', 'w')}}",
        f"(_ := open('{s}', 'w'))",
        f"x if open('{s}', 'w') else y",
        f"exp.__globals__['__builtins__']['open']('{s}', 'w')",
        "().__class__.__bases__[0].__subclasses__()",
        "x.__class__",
        "x.real",
        "x[0]",
        "globals()",
        "locals()",
        "compile('1', 'f', 'eval')",
        "getattr(x, 'real')",
        "Symbol('x')",
        "sympify('x')",
        "Function('f')(x)",
        "exp(x=1)",
        "exp(*[x])",
        "exp(x, y)",
        "'x'",
        "b'x'",
        "f'{x}'",
        "x ^ 2",
        "x and y",
        "x < y",
        "not x",
        "x @ y",
        "x // y",
        "x % y",
        "9**9**9**9",
        "1e999 * x",
        "1j * x",
        "True * x",
        "None",
        "...",
        "unknown_parameter * x",
        "__builtins__",
        "x; import os",
        "import os",
        "",
        "x" * 3000,
    ]
