"""The console's pages (thesis A8.5: Pg 100, Statistics 6xx, Demo 710, Data 8xx), one
module per page, registered by number."""
