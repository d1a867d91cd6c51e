import * as THREE from 'three';
import { reason } from './api.js';
import { describeOne, listDescriptions } from './commission_api.js';
import { button, element, setText } from './dom.js';
import { matrixOf7 } from './calibrate.js';

const GHOST = 0x19a7ce;
const BALL = 0.02; // m

/**
 * Picking a description for a robot that has none yet (drawn as stand-ins, or a
 * TODO left by `discover`): the server lists the URDF and xacro files on its
 * machine with the robot's number of joints (the cell's folder, description
 * packages installed in its environment, ROS package paths); one is previewed
 * as a ball-and-stick ghost where the robot stands, with its joints matched to
 * the robot's nodes (in order, or as chosen); "Use" writes it into the cell
 * (unsaved until saved).
 */
class DescriptionPicker {

	constructor( container, stage, edits ) {

		this.edits = edits;
		this.view = null;
		this.found = [];
		this.preview = null; // GET /api/descriptions/{id}
		this.ghost = new THREE.Group();
		this.ghost.name = 'description preview';
		this.ghost.matrixAutoUpdate = false;
		stage.world.add( this.ghost );

		this.el = element( 'fieldset', 'describe' );
		this.legend = element( 'legend', null, 'Description' );
		this.stateEl = element( 'p', 'muted' );
		this.findButton = edits.guard( button( 'Find descriptions', 'list the robot descriptions on the server\'s machine with this robot\'s number of joints' ) );
		this.list = element( 'ul', 'found' );
		this.list.setAttribute( 'aria-label', 'descriptions found' );
		this.previewEl = element( 'div', 'preview' );
		this.messageEl = element( 'p', 'describe-message' );
		this.messageEl.setAttribute( 'role', 'status' );
		this.el.append( this.legend, this.stateEl, this.findButton, this.list, this.previewEl, this.messageEl );
		container.append( this.el );
		this.findButton.addEventListener( 'click', () => this.find() );

	}

	setRobot( view ) {

		const same = view !== null && this.view !== null && view.name === this.view.name;
		this.view = view;
		this.el.hidden = view === null;
		if ( ! same ) this._reset();
		if ( view === null ) return;
		setText( this.legend, `Description of ${view.name}` );
		const bare = view.info.links.every( ( link ) => link.mesh === null );
		setText( this.stateEl, `${view.info.kinematics}, ${view.info.joints.length} joints${bare ? ', no meshes: drawn as ball and stick' : ''}.` );
		if ( this.preview ) this._drawGhost(); // the robot may have moved

	}

	_reset() {

		this.found = [];
		this.list.replaceChildren();
		this._closePreview();
		setText( this.messageEl, '' );

	}

	async find() {

		if ( ! this.view ) return;
		setText( this.messageEl, 'Looking…' );
		const result = await listDescriptions( this.view.name );
		if ( ! result.ok ) return setText( this.messageEl, reason( result ) );
		const { found, examined, pending } = result.body;
		this.found = found;
		setText( this.messageEl, `${found.length} of ${examined} files have ${result.body.joints} joints${pending ? ` (${pending} not looked at yet: find again)` : ''}.` );
		this.list.replaceChildren( ...found.map( ( entry ) => {

			const item = element( 'li' );
			const pick = button( entry.name, `preview ${entry.file}`, 'btn btn-small' );
			pick.addEventListener( 'click', () => this.show( entry.id ) );
			item.append( pick, element( 'span', 'muted', ` ${entry.origin}: ${entry.file}` ) );
			return item;

		} ) );

	}

	async show( id ) {

		const result = await describeOne( id );
		if ( ! result.ok ) return setText( this.messageEl, reason( result ) );
		this.preview = result.body;
		this._drawGhost();
		this._buildOrder();

	}

	// Which of the description's joints each of the robot's nodes drives: in order unless chosen.
	_buildOrder() {

		const names = this.preview.joints.map( ( entry ) => entry.name );
		const table = element( 'table', 'joint-order' );
		table.setAttribute( 'aria-label', 'joint order' );
		this.selects = this.view.info.joints.map( ( joint, i ) => {

			const row = element( 'tr' );
			const select = element( 'select' );
			select.setAttribute( 'aria-label', `description joint driven by ${joint.node}` );
			for ( const name of names ) select.append( new Option( name, name, false, name === names[ i ] ) );
			const node = element( 'td', 'node' );
			node.append( element( 'code', null, joint.node ) );
			const choice = element( 'td' );
			choice.append( select );
			row.append( node, choice );
			table.append( row );
			return select;

		} );
		const use = this.edits.guard( button( 'Use this description', `describe ${this.view.name} by ${this.preview.file}`, 'btn btn-primary' ) );
		use.addEventListener( 'click', () => this.use() );
		const close = button( 'Close preview', 'close the preview' );
		close.addEventListener( 'click', () => this._closePreview() );
		const tools = element( 'div', 'toolbar' );
		tools.append( use, close );
		this.previewEl.replaceChildren( element( 'p', null, `${this.preview.name}: ${this.preview.file}` ), table, tools );

	}

	async use() {

		if ( ! this.preview || ! this.view ) return;
		const order = this.selects.map( ( select ) => select.value );
		const result = await this.edits.change( [ { op: 'description', robot: this.view.name, id: this.preview.id, joints: order } ] );
		setText( this.messageEl, result.ok ? `${this.view.name} is described by ${this.preview.file} (unsaved).` : reason( result ) );
		if ( result.ok ) this._closePreview();

	}

	_drawGhost() {

		this._clearGhost();
		const material = new THREE.MeshBasicMaterial( { color: GHOST, transparent: true, opacity: 0.55, depthTest: false } );
		const lines = new THREE.LineBasicMaterial( { color: GHOST, depthTest: false } );
		const ball = new THREE.SphereGeometry( BALL, 12, 8 );
		const points = [];
		for ( const part of this.preview.links ) {

			const at = matrixOf7( part.pose );
			const centre = new THREE.Vector3().setFromMatrixPosition( at );
			const mesh = new THREE.Mesh( ball, material );
			mesh.position.copy( centre );
			mesh.renderOrder = 15;
			this.ghost.add( mesh );
			for ( const end of part.ends ) points.push( centre, new THREE.Vector3().fromArray( end ).applyMatrix4( at ) );

		}
		const sticks = new THREE.LineSegments( new THREE.BufferGeometry().setFromPoints( points ), lines );
		sticks.renderOrder = 15;
		this.ghost.add( sticks );
		matrixOf7( this.view.info.base, this.ghost.matrix );
		this.ghost.matrixWorldNeedsUpdate = true;

	}

	_clearGhost() {

		this.ghost.traverse( ( child ) => {

			child.geometry?.dispose();
			child.material?.dispose();

		} );
		this.ghost.clear();

	}

	_closePreview() {

		this.preview = null;
		this.selects = [];
		this.previewEl.replaceChildren();
		this._clearGhost();

	}

	/** What the picker shows (tests). */
	shown() {

		return {
			robot: this.view?.name ?? null, found: this.found, preview: this.preview ? { id: this.preview.id, file: this.preview.file, links: this.preview.links.length } : null,
			ghostParts: this.ghost.children.length, message: this.messageEl.textContent,
		};

	}

	dispose() {

		this._clearGhost();
		this.ghost.removeFromParent();

	}

}

export { DescriptionPicker };
