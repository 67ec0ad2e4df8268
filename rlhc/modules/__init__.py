"""Networks: actors, worker critics and manager critics, built from env specs."""
