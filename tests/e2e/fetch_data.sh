# End-to-end: scripts/fetch-data.sh (`make data`) offline, on a small manifest:
# a local mirror (GS_DATA_MIRROR) fills a data root with verified files; a
# second run fetches nothing; a checksum mismatch, a file missing from the
# mirror and a corrupted file already in place are each reported by name and
# never installed; items select files; the download path builds the
# raw.githubusercontent.com URL (a stand-in curl on PATH, no network). Then the
# real manifest: well-formed rows, and none of its files committed in data/
# while every one is git-ignored there.
source "$GS_ROOT/tests/e2e/lib.bash"
unset GS_DATA GS_DATA_MIRROR GS_DATA_MANIFEST # only what each command below sets
FETCH=$GS_ROOT/scripts/fetch-data.sh
sha() { sha256sum "$1" | cut -d' ' -f1; }

mkdir -p mirror/sub mirror/other
printf 'alpha\n' > mirror/a.txt
printf 'bravo with a space in its name\n' > "mirror/sub/b c.bin"
printf 'delta\n' > mirror/other/d.txt
C=0123456789abcdef0123456789abcdef01234567
{
  echo "# test manifest"
  printf 'a.txt\t%s\t6\towner/repo\t%s\tpath/a.txt\n' "$(sha mirror/a.txt)" "$C"
  printf 'sub/b c.bin\t%s\t31\towner/repo\t%s\tdir with space/b c.bin\n' "$(sha "mirror/sub/b c.bin")" "$C"
  printf 'other/d.txt\t%s\t6\tother/repo\t%s\td.txt\n' "$(sha mirror/other/d.txt)" "$C"
} > manifest.tsv
export GS_DATA_MANIFEST=$PWD/manifest.tsv

# --- success, then idempotent ------------------------------------------------
out=$(GS_DATA=root GS_DATA_MIRROR=mirror "$FETCH" 2>&1); rc=$?
[[ $rc -eq 0 ]] && ok "mirror fetch: exit 0" || bad "mirror fetch: rc $rc: $out"
cmp -s root/a.txt mirror/a.txt && cmp -s "root/sub/b c.bin" "mirror/sub/b c.bin" && cmp -s root/other/d.txt mirror/other/d.txt \
  && ok "every file installed under the (relative) GS_DATA root" || bad "files differ: $(ls -R root)"
grep -q "3 files: 3 fetched, 0 present already, 0 failed" <<<"$out" && ok "summary counts 3 fetched" || bad "summary: $out"
before=$(stat -c %Y.%i root/a.txt)
out=$(GS_DATA=$PWD/root GS_DATA_MIRROR=$PWD/mirror "$FETCH" 2>&1); rc=$?
[[ $rc -eq 0 ]] && grep -q "0 fetched, 3 present already" <<<"$out" && ok "second run: nothing fetched" || bad "second run: $out"
[[ $(stat -c %Y.%i root/a.txt) == "$before" ]] && ok "second run leaves files alone" || bad "a.txt was rewritten"

# --- items -------------------------------------------------------------------------
out=$(GS_DATA=sel GS_DATA_MIRROR=mirror "$FETCH" sub/ 2>&1)
[[ -f "sel/sub/b c.bin" && ! -e sel/a.txt && ! -e sel/other ]] && grep -q "1 files: 1 fetched" <<<"$out" \
  && ok "an item (folder) fetches only what is under it" || bad "item sub: $out; $(ls -R sel)"
out=$(GS_DATA=sel GS_DATA_MIRROR=mirror "$FETCH" nosuch 2>&1); rc=$?
[[ $rc -eq 2 ]] && grep -q "'nosuch' is not in the manifest" <<<"$out" && ok "unknown item: exit 2, named" || bad "unknown item: rc $rc $out"
"$FETCH" --has "sub/b c.bin" && ! "$FETCH" --has sub && ok "--has: exact destinations only" || bad "--has"
[[ $("$FETCH" --list | wc -l) -eq 3 ]] && "$FETCH" --list | grep -qF "owner/repo@$C:dir with space/b c.bin" \
  && ok "--list names destination and origin" || bad "--list: $("$FETCH" --list)"

# --- failures: mismatch, missing in the mirror, corrupted file in place ------------
cp -r mirror badmirror
printf 'tampered\n' > badmirror/a.txt
rm badmirror/other/d.txt
mkdir -p bad/sub && printf 'corrupt\n' > "bad/sub/b c.bin"
out=$(GS_DATA=bad GS_DATA_MIRROR=badmirror "$FETCH" 2>&1); rc=$?
[[ $rc -eq 1 ]] && ok "failures: exit 1" || bad "failures: rc $rc"
grep -q "FAILED a.txt: checksum mismatch for $PWD/badmirror/a.txt: sha256 $(sha badmirror/a.txt), expected $(sha mirror/a.txt)" <<<"$out" \
  && ok "checksum mismatch named with both sums" || bad "mismatch message: $out"
[[ ! -e bad/a.txt ]] && ok "the mismatching file is not installed" || bad "bad/a.txt installed"
grep -q "FAILED other/d.txt: not in the mirror $PWD/badmirror" <<<"$out" && ok "missing file named" || bad "missing message: $out"
grep -q "sub/b c.bin: present but its checksum differs: replacing it" <<<"$out" && cmp -s "bad/sub/b c.bin" "mirror/sub/b c.bin" \
  && ok "a corrupted file in place is replaced by the verified one" || bad "corrupt file: $out"
grep -q "3 files: 1 fetched, 0 present already, 2 failed" <<<"$out" && ok "summary counts the failures" || bad "summary: $out"
left=$(find bad -name '.*.fetch-*')
[[ -z $left ]] && ok "no temporary file left behind" || bad "temporaries left: $left"

# --- the download path: URL at the pinned commit, %-encoded (stand-in curl) --------
mkdir -p fakebin
cat > fakebin/curl <<EOF
#!/usr/bin/env bash
# stand-in for curl: records the URL, serves the mirror's file for it
out="" url=""
while [[ \$# -gt 0 ]]; do case \$1 in -o) out=\$2; shift 2 ;; --) url=\$2; shift 2 ;; -*) shift ;; *) url=\$1; shift ;; esac; done
echo "\$url" >> "$PWD/urls.txt"
case \$url in
  */owner/repo/$C/path/a.txt) cp "$PWD/mirror/a.txt" "\$out" ;;
  */owner/repo/$C/dir%20with%20space/b%20c.bin) cp "$PWD/mirror/sub/b c.bin" "\$out" ;;
  *) exit 22 ;;
esac
EOF
chmod +x fakebin/curl
out=$(PATH=$PWD/fakebin:$PATH GS_DATA=dl "$FETCH" 2>&1); rc=$?
grep -qx "https://raw.githubusercontent.com/owner/repo/$C/dir%20with%20space/b%20c.bin" urls.txt \
  && ok "download URL: raw.githubusercontent.com/OWNER/REPO/COMMIT/PATH, blanks %-encoded" || bad "URLs: $(cat urls.txt)"
[[ $rc -eq 1 && -f dl/a.txt && -f "dl/sub/b c.bin" && ! -e dl/other/d.txt ]] \
  && grep -q "FAILED other/d.txt: download of https://raw.githubusercontent.com/other/repo/$C/d.txt failed" <<<"$out" \
  && ok "downloads verified and installed; a failed download is named, exit 1" || bad "download run: rc $rc $out"

# --- a malformed manifest ------------------------------------------------------------
printf 'x.txt\tnotasha\t1\to/r\t%s\tx\n' "$C" > broken.tsv
out=$(GS_DATA_MANIFEST=$PWD/broken.tsv GS_DATA=b2 "$FETCH" 2>&1); rc=$?
[[ $rc -eq 2 ]] && grep -q "bad row for 'x.txt'" <<<"$out" && ok "malformed manifest row: exit 2, named" || bad "broken manifest: rc $rc $out"

# --- the real manifest ------------------------------------------------------------------
unset GS_DATA_MANIFEST
M=$GS_ROOT/scripts/data-manifest.tsv
nrows=$(grep -vc '^#' "$M")
bad_rows=$(grep -v '^#' "$M" | grep -vP '^[^\t]+\t[0-9a-f]{64}\t[0-9]+\t[^\t/]+/[^\t/]+\t[0-9a-f]{40}\t[^\t]+$')
[[ $nrows -gt 100 && -z $bad_rows ]] && ok "real manifest: $nrows rows, each with sha256, size, 40-hex commit, path" \
  || bad "real manifest rows: $bad_rows"
if git -C "$GS_ROOT" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t paths < <(cut -f1 "$M" | grep -v '^#' | sed 's|^|data/|')
  committed=$(git -C "$GS_ROOT" ls-files -- "${paths[@]}" | head -3)
  [[ -z $committed ]] && ok "no fetched file is committed in data/" || bad "committed: $committed"
  notignored=$(cut -f1 "$M" | grep -v '^#' | while IFS= read -r d; do
    git -C "$GS_ROOT" check-ignore -q --no-index "data/$d" || echo "$d"; done | head -3)
  [[ -z $notignored ]] && ok "every fetched file is git-ignored under data/" || bad "not ignored: $notignored"
else
  skipped "manifest vs git: $GS_ROOT is not a git checkout"
fi
finish
