#!/bin/bash
# memwatch.sh CMD...: runs CMD, samples its RssAnon/RssFile every 0.2 s, prints the maxima.
"$@" & pid=$!
maxa=0; maxf=0
while kill -0 $pid 2>/dev/null; do
  read a f < <(awk '/RssAnon/{a=$2} /RssFile/{f=$2} END{print a+0, f+0}' /proc/$pid/status 2>/dev/null)
  [ "${a:-0}" -gt "$maxa" ] && maxa=$a; [ "${f:-0}" -gt "$maxf" ] && maxf=$f
  sleep 0.2
done
wait $pid; rc=$?
echo "rc=$rc max RssAnon $((maxa/1024)) MB, max RssFile $((maxf/1024)) MB"
