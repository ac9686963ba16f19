// Tokenizes .fhl files with VS Code's own TextMate engine (vscode-textmate and
// vscode-oniguruma, installed by tests/editors/test_textmate.py) and prints,
// as JSON, each file's tokens: [line, start, end, innermost scope].
// Usage: node tokenize.cjs GRAMMAR.json FILE...
"use strict";
const fs = require("fs");
const path = require("path");
const textmate = require("vscode-textmate");
const oniguruma = require("vscode-oniguruma");

const [grammarPath, ...files] = process.argv.slice(2);
const wasm = fs.readFileSync(path.join(path.dirname(require.resolve("vscode-oniguruma")), "onig.wasm"));
const onigLib = oniguruma.loadWASM(wasm.buffer).then(() => ({
  createOnigScanner: (patterns) => new oniguruma.OnigScanner(patterns),
  createOnigString: (text) => new oniguruma.OnigString(text),
}));
const registry = new textmate.Registry({
  onigLib,
  loadGrammar: async () => textmate.parseRawGrammar(fs.readFileSync(grammarPath, "utf8"), grammarPath),
});

registry.loadGrammar("source.fhl").then((grammar) => {
  const out = {};
  for (const file of files) {
    let state = textmate.INITIAL;
    const tokens = [];
    fs.readFileSync(file, "utf8").split("\n").forEach((text, line) => {
      const result = grammar.tokenizeLine(text, state);
      for (const token of result.tokens) {
        tokens.push([line + 1, token.startIndex, Math.min(token.endIndex, text.length), token.scopes[token.scopes.length - 1]]);
      }
      state = result.ruleStack;
    });
    out[file] = tokens;
  }
  process.stdout.write(JSON.stringify(out));
});
