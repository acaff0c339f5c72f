"""The validation floor: benchmarks (``bench``), work-precision studies (``precision``), the
numerical stability suite (``stability``), the seed 003 reproduction (``reproduce``) and
independent scipy references (``reference``), with their scenes as scenario files
(``scenes``).

It stands on the engine and the engine never imports it (``tests/integration/test_layout.py``), except
lazily inside the ``vines-stoch bench`` and ``vines-stoch reproduce`` commands.  Its extra
dependencies are optional: ``bench`` compares against sdeint (``pip install
"vines-stoch[bench]"``) and draws its diagrams with matplotlib where installed
(``[report]``).
"""
