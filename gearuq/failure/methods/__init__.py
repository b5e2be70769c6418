"""One module per failure-probability method; the table that lists them is in
:mod:`gearuq.failure.api`."""
