// Starts `advise lsp` for `.adv` files. Install: `npm install` here, then copy or link this folder
// into ~/.vscode/extensions/ (or run it with F5 from VS Code opened on this folder).
const vscode = require('vscode');
const { LanguageClient } = require('vscode-languageclient/node');

let client;

function activate() {
  const command = vscode.workspace.getConfiguration('advise').get('path') || 'advise';
  client = new LanguageClient(
    'advise',
    'advise',
    { command, args: ['lsp'] },
    { documentSelector: [{ scheme: 'file', language: 'advise' }] },
  );
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
