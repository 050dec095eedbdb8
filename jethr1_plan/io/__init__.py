"""Every file jethr1 reads or writes: atomic writes (:mod:`.atomic`), the trajectory CSV
(:mod:`.trajectory_csv`), MCAP (:mod:`.mcap`), the plan folder (:mod:`.plan_files`), the balance-space
files (:mod:`.balance_space_files`) and JSON documents (:mod:`.json_text`)."""

__all__: list[str] = []
