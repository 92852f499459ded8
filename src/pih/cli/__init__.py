"""The command line (``pih``): the row query of ``pih replay`` (:mod:`.row_query`, parsed and
never evaluated). May import every other subpackage; nothing imports it but
:mod:`pih.__main__`."""
