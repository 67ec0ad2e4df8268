#!/bin/bash
# Soccer paper preset, RLHC: compile=true vs eager, seeds 0-2, resumable.
cd "$(dirname "$0")/../../../.."
R=benchmarks/results/compile/soccer
mkdir -p $R/evaluations
for S in 0 1 2; do
 for MODE in compiled eager; do
  C=false; [ $MODE = compiled ] && C=true
  D=$R/runs/$MODE/seed_$S
  if [ ! -f $D/final_team.pt ]; then
   .venv/bin/python -m rlhc.run env=soccer critic=hierarchical seed=$S threads=1 logger.backends=[csv] logger.progress=false checkpoint_freq=50000 resume=auto compile=$C hydra.run.dir=$D || exit 1
  fi
  for AWAY in scripted random; do
   O=$R/evaluations/${MODE}_${S}_${AWAY}.json
   if [ ! -f $O ]; then
    .venv/bin/python -m rlhc.evaluate env=soccer home=$D away=$AWAY matches=100 hydra.run.dir=/tmp/eval_${MODE}_${S}_${AWAY} && cp /tmp/eval_${MODE}_${S}_${AWAY}/results.json $O
   fi
  done
 done
done
echo ALLDONE
