import { reason } from './api.js';
import { cellStatus, changeCell, discardChanges, saveCell, undoSave } from './commission_api.js';
import { button, element, setText } from './dom.js';

const OFF = 'Editing the cell is off: start linkview with --allow-edits (or put allow_edits = true at the top of the cell file).';

/**
 * The cell file's changes made from this page (server/commissioning/session.py):
 * each runs at once, unsaved; "Review and save" shows the diff, and only then
 * can it be written (the server keeps the file before as <file>.bak); Discard
 * drops them; "Undo last save" puts the file before back. Every control that
 * changes the cell is `guard`ed: disabled, with how to allow edits as its title,
 * while the server does not allow them.
 */
class CellEdits {

	constructor( container ) {

		this.status = null; // GET /api/cell
		this.shownVersion = null; // the unsaved version whose diff is on screen
		this.message = '';
		this._guarded = new Set();
		this._listeners = [];
		this.el = element( 'div', 'cell-edits' );
		this.stateEl = element( 'p', 'edit-state muted' );
		this.stateEl.setAttribute( 'role', 'status' );
		this.bar = element( 'div', 'toolbar unsaved' );
		this.countEl = element( 'span', 'unsaved-count' );
		this.reviewButton = button( 'Review and save…', 'show the diff of the unsaved changes to the cell file' );
		this.discardButton = button( 'Discard', 'discard the unsaved changes to the cell file' );
		this.bar.append( this.countEl, this.reviewButton, this.discardButton );
		this.undoButton = button( 'Undo last save', 'put the cell file as it was before the last save back' );
		this.diffEl = element( 'div', 'diff-view' );
		this.diffEl.hidden = true;
		this.diffText = element( 'pre', 'diff' );
		this.diffText.setAttribute( 'aria-label', 'diff of the unsaved changes' );
		this.saveButton = button( 'Write the cell file', 'write the changes shown to the cell file', 'btn btn-primary' );
		const close = button( 'Close', 'close the diff' );
		const actions = element( 'div', 'toolbar' );
		actions.append( this.saveButton, close );
		this.diffEl.append( this.diffText, actions );
		this.messageEl = element( 'p', 'edit-message' );
		this.messageEl.setAttribute( 'role', 'status' );
		this.el.append( this.stateEl, this.bar, this.undoButton, this.diffEl, this.messageEl );
		container.append( this.el );
		for ( const control of [ this.reviewButton, this.discardButton, this.undoButton, this.saveButton ] ) this.guard( control );
		this.reviewButton.addEventListener( 'click', () => this.review() );
		this.discardButton.addEventListener( 'click', () => this._act( discardChanges(), 'Changes discarded.' ) );
		this.undoButton.addEventListener( 'click', () => this._act( undoSave(), 'The file before the last save is back; the server reloads it.' ) );
		this.saveButton.addEventListener( 'click', () => this.save() );
		close.addEventListener( 'click', () => this._closeDiff() );
		this._render();

	}

	get editable() {

		return this.status !== null && this.status.editable;

	}

	/** Why changes are refused, and how to allow them (null: allowed). */
	get whyNot() {

		if ( this.status === null ) return OFF;
		if ( this.status.editable ) return null;
		const text = this.status.why_not;
		return `${text.charAt( 0 ).toUpperCase()}${text.slice( 1 )}.`;

	}

	/** Disable `control` while edits are not allowed, its title saying how to allow them. */
	guard( control ) {

		control.dataset.edit = '';
		this._guarded.add( control );
		this._apply( control );
		return control;

	}

	/** Forget the guarded controls that left the page (a rebuilt table or panel). */
	prune() {

		for ( const control of this._guarded ) if ( ! control.isConnected ) this._guarded.delete( control );

	}

	onChange( listener ) {

		this._listeners.push( listener );

	}

	async refresh() {

		const result = await cellStatus();
		if ( result.ok ) this._set( result.body );
		return result;

	}

	/** Make `changes` (server/commissioning/changes.py): run at once, unsaved. */
	async change( changes ) {

		const result = await changeCell( changes );
		if ( result.ok ) {

			this._set( result.body );
			this._say( '' );

		} else {

			this._say( `Not changed: ${reason( result )}` );

		}
		return result;

	}

	/** Show the diff of the unsaved changes; only what was shown can be written. */
	async review() {

		await this.refresh();
		const unsaved = this.status?.unsaved;
		if ( ! unsaved ) return;
		this.shownVersion = unsaved.version;
		// One line each, coloured as diff -u reads: what goes, what comes, where.
		this.diffText.replaceChildren( ...unsaved.diff.split( /(?<=\n)/ ).map( ( line ) => {

			const kind = line.startsWith( '@@' ) ? 'hunk' : line.startsWith( '+' ) ? 'add' : line.startsWith( '-' ) ? 'del' : null;
			return element( 'span', kind, line );

		} ) );
		this.diffEl.hidden = false;
		this._render();

	}

	async save() {

		if ( this.shownVersion === null ) return;
		const result = await this._act( saveCell( this.shownVersion ), 'Saved; the previous file is kept as a backup.' );
		if ( result.ok ) this._closeDiff();

	}

	async _act( request, done ) {

		const result = await request;
		if ( result.ok ) this._set( result.body );
		this._say( result.ok ? done : reason( result ) );
		return result;

	}

	_closeDiff() {

		this.diffEl.hidden = true;
		this.shownVersion = null;
		this._render();

	}

	_say( text ) {

		this.message = text;
		setText( this.messageEl, text );

	}

	_set( cell ) {

		this.status = cell;
		if ( this.shownVersion !== null && cell.unsaved?.version !== this.shownVersion ) this._closeDiff();
		this._render();
		for ( const listener of this._listeners ) listener( cell );

	}

	_apply( control ) {

		const why = this.whyNot;
		control.disabled = why !== null;
		control.title = why ?? control.getAttribute( 'aria-label' ) ?? '';

	}

	_render() {

		const cell = this.status;
		const unsaved = cell?.unsaved ?? null;
		setText( this.stateEl, this.editable
			? `Changes to ${cell.path} run at once; nothing is written until you save.`
			: this.whyNot );
		this.bar.hidden = unsaved === null;
		if ( unsaved ) setText( this.countEl, `${unsaved.changes} unsaved change${unsaved.changes === 1 ? '' : 's'}${unsaved.stale ? ' (the file changed on disk since)' : ''}` );
		this.undoButton.hidden = ! cell?.backup || unsaved !== null;
		for ( const control of this._guarded ) this._apply( control );
		this.saveButton.disabled = this.saveButton.disabled || this.shownVersion === null;

	}

	/** What the page shows (tests): editable, why not, unsaved count, the diff on screen. */
	shown() {

		return {
			editable: this.editable, whyNot: this.whyNot, unsaved: this.status?.unsaved?.changes ?? 0,
			diff: this.diffEl.hidden ? null : this.diffText.textContent, backup: this.status?.backup ?? null,
			message: this.message,
		};

	}

}

export { CellEdits };
