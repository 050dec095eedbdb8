"""Every file format jethr1 writes and reads, one module each: the plan folder, the walk folder,
the balance-space files, the rehearsal's files and the MCAP container they share."""
