"""The console's pages (thesis A8.5: Pg 100, Statistics 6xx, Demo 710, Data 8xx): Pg 100
(``main_page``), one ``pNNN_…`` module per numbered page, and their registry (``registry``)."""
