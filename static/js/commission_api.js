// The REST calls of commissioning (server/web/calibrate.py, server/web/cell_edits.py): SI units,
// same origin, JSON. Each answers { status, ok, body } as api.js's calls do.
import { post } from './api.js';

async function get( path ) {

	const response = await fetch( path );
	let body = null;
	try {

		body = await response.json();

	} catch {

		body = null;

	}
	return { status: response.status, ok: response.ok, body };

}

const named = ( name ) => encodeURIComponent( name );

/** A sample: the robot's TCP now, { tcp, world } as UR pose vectors (m, rad), its joints (SI). */
const sampleTcp = ( name ) => get( `/api/robots/${named( name )}/tcp` );
/** MotionPlus's calibrate_rotary_axis / calibrate_linear_axis over HTTP. */
const calibrate = ( body ) => post( '/api/calibrate', body );
/** Whether the cell may be changed (else why not), its unsaved changes with their diff. */
const cellStatus = () => get( '/api/cell' );
const changeCell = ( changes ) => post( '/api/cell/changes', { changes } );
const saveCell = ( version ) => post( '/api/cell/save', { version } );
const discardChanges = () => post( '/api/cell/discard', {} );
const undoSave = () => post( '/api/cell/undo', {} );
/** Descriptions on the server's machine with as many joints as `robotName` has. */
const listDescriptions = ( robotName ) => get( `/api/descriptions?robot=${named( robotName )}` );
const describeOne = ( id ) => get( `/api/descriptions/${named( id )}` );

export { calibrate, cellStatus, changeCell, describeOne, discardChanges, listDescriptions, sampleTcp, saveCell, undoSave };
