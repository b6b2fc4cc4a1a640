"""The console's pages: Pg 100 (``main_page``), one ``pNNN_…`` module per numbered page, and
their registry (``registry``)."""
