"""Thin input and output helpers every file format uses: YAML documents checked against a schema
(:mod:`.yaml_input`), JSON text (:mod:`.json_text`), wide CSV tables (:mod:`.csv_table`), atomic
staging and commit of outputs (:mod:`.atomic`) and the Dask client of scale-out runs (:mod:`.cluster`).
The file formats themselves live in :mod:`jethr1_plan.files`."""
