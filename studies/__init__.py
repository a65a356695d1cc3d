"""Studies: evaluations that combine the world, the learners and the drivers.

Each study is a function returning a typed result; :mod:`.reports` writes their Markdown
and :mod:`.figures` draws their figures. Scripts parse arguments, call a study, write files.
"""
