"""Model files: a hybrid model as safe, shareable TOML text. Reading (:mod:`.read`,
:mod:`.part`, :mod:`.build`), writing (:mod:`.write`), their source positions
(:mod:`.source`, :mod:`.tomllines`) and errors (:mod:`.errors`); the entry points
are in :mod:`.modelfile`.
"""
